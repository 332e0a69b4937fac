"""Stage's model properties read through the simulation interface (GET_PROPERTY).

Values are packed as a C client reads them on the machine it runs on (little-endian here):
`_mp_color` / `color` four float32 RGBA in 0..1; `_mp_fiducial_return` / `fiducial_return`,
`_mp_gripper_return` / `gripper_return`, `_mp_obstacle_return` / `obstacle_return` an int32;
`_mp_mass` / `mass` a float64 (kg); `_mp_size` / `size` three float64 (m); `_mp_watts`
a float64 (W). `set_property` reads a SET_PROPERTY's value for the two properties that can
change here: `color` (four float32 RGBA, alpha ignored) of a robot, box, object, marker or
charger, and `fiducial_return` (an int32 >= 0) of a robot or object; anything else is
refused (KeyError, ValueError: NACKed).
"""

from __future__ import annotations

import math
import struct
from typing import Any, Protocol


class LooksNow(Protocol):
    """The colours and fiducial ids in force (`player_server.sim.looks.Looks`)."""

    def colour(self, name: str) -> int: ...

    def fiducial_id(self, name: str) -> int: ...


_RGBA = struct.Struct("<4f")
_INT = struct.Struct("<i")
_F64 = struct.Struct("<d")
_SIZE = struct.Struct("<3d")


def _thing(spec: Any, name: str) -> tuple[str, Any]:
    for kind, items in (("robot", spec.robots), ("object", spec.objects),
                        ("box", spec.boxes), ("obstacle", spec.arena.obstacles),
                        ("charger", spec.chargers), ("marker", spec.markers)):
        for it in items:
            if it.name == name:
                return kind, it
    raise KeyError(f"no model named {name!r}")


def model_property(spec: Any, name: str, prop: str, looks: LooksNow | None = None) -> bytes:
    """The packed value of a property (colours and fiducial ids as ``looks`` has them now);
    KeyError (NACKed) for unknown models or properties."""
    kind, it = _thing(spec, name)
    key = prop.removeprefix("_mp_")
    if key == "color":
        c = int(looks.colour(name)) if looks and kind not in ("obstacle",) else int(it.colour)
        return _RGBA.pack(((c >> 16) & 255) / 255.0, ((c >> 8) & 255) / 255.0,
                          (c & 255) / 255.0, 1.0)
    if key == "fiducial_return":
        if looks is not None and kind in ("robot", "object"):
            return _INT.pack(int(looks.fiducial_id(name)))
        return _INT.pack(int(getattr(it, "fiducial_id", 0)))
    if key == "gripper_return":
        return _INT.pack(1 if kind == "object" else 0)
    if key == "obstacle_return":
        return _INT.pack(0 if kind in ("marker", "charger") else 1)
    if key == "mass":
        mass = it.body.mass_kg if kind == "robot" else getattr(it, "mass_kg", 0.0)
        return _F64.pack(float(mass))
    if key == "size":
        if kind == "robot":
            return _SIZE.pack(it.body.length_m, it.body.width_m, it.body.height_m)
        if kind == "object":
            return _SIZE.pack(2 * it.radius_m, 2 * it.radius_m, it.height_m)
        if kind in ("obstacle",):
            return _SIZE.pack(it.size_x_m, it.size_y_m, it.height_m)
        if kind == "box":
            return _SIZE.pack(it.size_x_m, it.size_y_m, it.size_z_m)
    if key == "watts" and kind == "robot" and it.devices.power is not None:
        return _F64.pack(float(it.devices.power.idle_w))
    if key == "watts" and kind == "charger":
        return _F64.pack(float(it.rate_w))
    raise KeyError(f"model {name!r} has no property {prop!r} here")


def property_change(prop: str, value: bytes) -> dict[str, int]:
    """The `set_looks` arguments of a SET_PROPERTY (ValueError, KeyError: NACKed)."""
    key = prop.removeprefix("_mp_")
    if key == "color":
        if len(value) != _RGBA.size:
            raise ValueError(f"color takes four float32 (RGBA, {_RGBA.size} bytes), "
                             f"not {len(value)} bytes")
        rgb = _RGBA.unpack(value)[:3]
        if not all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in rgb):
            raise ValueError(f"color components must be in 0..1, not {rgb}")
        r, g, b = (round(v * 255) for v in rgb)
        return {"colour": (r << 16) | (g << 8) | b}
    if key == "fiducial_return":
        if len(value) != _INT.size:
            raise ValueError(f"fiducial_return takes an int32 ({_INT.size} bytes), "
                             f"not {len(value)} bytes")
        (fid,) = _INT.unpack(value)
        if fid < 0:
            raise ValueError(f"fiducial_return must be >= 0, not {fid}")
        return {"fiducial_id": fid}
    raise KeyError(f"property {prop!r} cannot be set here (only color and fiducial_return)")
