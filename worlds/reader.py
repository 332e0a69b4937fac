"""Typed, path-aware access to a parsed TOML table; every failure is a WorldError."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from worlds.colours import parse_colour
from worlds.errors import WorldError
from worlds.spec import Mount, Pose

_MISSING = object()


def _type_name(value: object) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    if isinstance(value, dict):
        return "table"
    return type(value).__name__


class Table:
    """One TOML table and its dotted key path; tracks which keys were read."""

    def __init__(self, file: Path, path: str, data: object) -> None:
        self.file = file
        self.path = path
        if not isinstance(data, dict):
            raise WorldError(file, path, "a table", data)
        self.data: dict[str, Any] = data
        self._used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, expected: str, found: object) -> WorldError:
        return WorldError(self.file, self.key(name), expected, found)

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str, default: object = _MISSING) -> Any:
        self._used.add(name)
        if name not in self.data:
            if default is _MISSING:
                raise self.error(name, "a value (required key)", "nothing")
            return default
        return self.data[name]

    def finish(self) -> None:
        """Reject keys that were never read (typos must not pass silently)."""
        unknown = sorted(set(self.data) - self._used)
        if unknown:
            known = ", ".join(sorted(self._used)) or "none"
            raise self.error(unknown[0], f"one of the known keys ({known})", unknown[0])

    # ---- scalars -------------------------------------------------------------------------
    def number(
        self,
        name: str,
        default: float | None = None,
        *,
        min_value: float | None = None,
        max_value: float | None = None,
        positive: bool = False,
    ) -> float:
        value = self.raw(name, _MISSING if default is None else default)
        return self.check_number(name, value, min_value, max_value, positive)

    def check_number(
        self,
        name: str,
        value: object,
        min_value: float | None = None,
        max_value: float | None = None,
        positive: bool = False,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(name, "a number", value)
        f = float(value)
        if not math.isfinite(f):
            raise self.error(name, "a finite number", value)
        if positive and f <= 0.0:
            raise self.error(name, "a number > 0", value)
        if min_value is not None and f < min_value:
            raise self.error(name, f"a number >= {min_value:g}", value)
        if max_value is not None and f > max_value:
            raise self.error(name, f"a number <= {max_value:g}", value)
        return f

    def integer(
        self, name: str, default: int | None = None, *, min_value: int | None = None,
        max_value: int | None = None,
    ) -> int:
        value = self.raw(name, _MISSING if default is None else default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(name, "an integer", value)
        if min_value is not None and value < min_value:
            raise self.error(name, f"an integer >= {min_value}", value)
        if max_value is not None and value > max_value:
            raise self.error(name, f"an integer <= {max_value}", value)
        return value

    def string(
        self, name: str, default: str | None = None, *, choices: tuple[str, ...] = ()
    ) -> str:
        value = self.raw(name, _MISSING if default is None else default)
        if not isinstance(value, str):
            raise self.error(name, "a string", value)
        if choices and value not in choices:
            raise self.error(name, "one of " + ", ".join(repr(c) for c in choices), value)
        return value

    def boolean(self, name: str, default: bool) -> bool:
        value = self.raw(name, default)
        if not isinstance(value, bool):
            raise self.error(name, "true or false", value)
        return value

    def colour(self, name: str, default: int | str | None = None) -> int:
        value = self.raw(name, _MISSING if default is None else default)
        try:
            return parse_colour(value)
        except ValueError:
            raise self.error(
                name, "a colour (0xRRGGBB integer, '#rrggbb' or a colour name)", value
            ) from None

    def angle(
        self,
        base: str,
        default_rad: float | None = None,
        *,
        min_rad: float | None = None,
        max_rad: float | None = None,
    ) -> float:
        """An angle given as ``<base>_deg`` or ``<base>_rad``; returned in radians."""
        deg_key, rad_key = f"{base}_deg", f"{base}_rad"
        has_deg, has_rad = self.has(deg_key), self.has(rad_key)
        self._used.update((deg_key, rad_key))
        if has_deg and has_rad:
            raise self.error(deg_key, f"only one of {deg_key} and {rad_key}", "both")
        if has_deg:
            rad = math.radians(self.check_number(deg_key, self.data[deg_key]))
            key = deg_key
        elif has_rad:
            rad = self.check_number(rad_key, self.data[rad_key])
            key = rad_key
        elif default_rad is not None:
            return default_rad
        else:
            raise self.error(deg_key, f"{deg_key} or {rad_key} (required)", "nothing")
        if min_rad is not None and rad < min_rad - 1e-12:
            raise self.error(key, f"an angle >= {math.degrees(min_rad):g} deg", self.data[key])
        if max_rad is not None and rad > max_rad + 1e-12:
            raise self.error(key, f"an angle <= {math.degrees(max_rad):g} deg", self.data[key])
        return rad

    # ---- compound values -------------------------------------------------------------------
    def vector(self, name: str, length: int, default: tuple[float, ...] | None = None,
               *, positive: bool = False) -> tuple[float, ...]:
        value = self.raw(name, _MISSING if default is None else list(default))
        if not isinstance(value, list) or len(value) != length:
            raise self.error(name, f"an array of {length} numbers", value)
        for v in value:
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise self.error(name, f"an array of {length} numbers", value)
            if positive and v <= 0:
                raise self.error(name, f"an array of {length} numbers > 0", value)
        return tuple(float(v) for v in value)

    def pose(self, name: str, default: Pose | None = None) -> Pose:
        """``[x, y, yaw_deg]`` or ``{x, y, yaw_deg | yaw_rad}``; yaw defaults to 0."""
        value = self.raw(name, _MISSING if default is None else default)
        if isinstance(value, Pose):
            return value
        if isinstance(value, list):
            if len(value) not in (2, 3) or any(
                isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
                for v in value
            ):
                raise self.error(name, "[x, y] or [x, y, yaw_deg] numbers", value)
            yaw = math.radians(value[2]) if len(value) == 3 else 0.0
            return Pose(float(value[0]), float(value[1]), yaw)
        if isinstance(value, dict):
            t = self.sub(name)
            pose = Pose(t.number("x"), t.number("y"), t.angle("yaw", 0.0))
            t.finish()
            return pose
        raise self.error(name, "[x, y, yaw_deg] or a table {x, y, yaw_deg}", value)

    def mount(self, name: str, default: Mount) -> Mount:
        """``[x, y, z, yaw_deg]`` or ``{x, y, z, yaw_deg | yaw_rad}`` relative to the robot."""
        value = self.raw(name, default)
        if isinstance(value, Mount):
            return value
        if isinstance(value, list):
            if len(value) != 4 or any(
                isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
                for v in value
            ):
                raise self.error(name, "[x, y, z, yaw_deg] numbers", value)
            return Mount(float(value[0]), float(value[1]), float(value[2]), math.radians(value[3]))
        if isinstance(value, dict):
            t = self.sub(name)
            m = Mount(
                t.number("x", default.x),
                t.number("y", default.y),
                t.number("z", default.z),
                t.angle("yaw", default.yaw),
            )
            t.finish()
            return m
        raise self.error(name, "[x, y, z, yaw_deg] or a table", value)

    def sub(self, name: str) -> Table:
        self._used.add(name)
        return Table(self.file, self.key(name), self.data.get(name, {}))

    def optional_sub(self, name: str) -> Table | None:
        if name not in self.data:
            self._used.add(name)
            return None
        return self.sub(name)

    def array_of_tables(self, name: str) -> list[Table]:
        value = self.raw(name, [])
        if not isinstance(value, list):
            raise self.error(name, "an array of tables ([[...]])", value)
        return [Table(self.file, f"{self.key(name)}[{i}]", v) for i, v in enumerate(value)]
