"""A `WorldSpec` written back as a TOML world file that `load_world` reads to the same spec.

Angles are written in radians (`*_rad` keys, poses as tables) so nothing is lost on the way
round; colours as `#rrggbb`. Used by `murdoch world convert X.world > x.toml`.
"""

from __future__ import annotations

import math
from typing import Any

from worlds.device_kinds import device_kinds
from worlds.spec import Mount, Pose, RobotSpec, WorldSpec

__all__ = ["world_to_toml"]


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write {v} to TOML")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, Pose):
        return f"{{ x = {v.x!r}, y = {v.y!r}, yaw_rad = {v.yaw!r} }}"
    if isinstance(v, Mount):
        return f"{{ x = {v.x!r}, y = {v.y!r}, z = {v.z!r}, yaw_rad = {v.yaw!r} }}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(type(v))


def _colour(c: int) -> str:
    return f"#{c:06x}"


def _table(header: str, items: list[tuple[str, Any]]) -> list[str]:
    return ["", header] + [f"{k} = {_value(v)}" for k, v in items]


def _robot(r: RobotSpec) -> list[str]:
    """The robot's table, its body and one table per device (each kind's own items)."""
    d = r.devices
    out = _table("[[robots]]", [("name", r.name), ("pose", r.pose), ("colour", _colour(r.colour)),
                                ("fiducial_id", r.fiducial_id)])
    b = r.body
    out += _table("[robots.body]", [("length", b.length_m), ("width", b.width_m),
                                    ("height", b.height_m), ("offset_x", b.offset_x_m),
                                    ("mass", b.mass_kg)]
                  + ([("outline", [list(p) for p in b.outline])] if b.outline else []))
    kinds = device_kinds()
    for name in d.names():
        out += _table(f"[robots.{name}]", kinds[name].items(d.get(name)))
    return out


def world_to_toml(w: WorldSpec) -> str:
    out = [f"# {w.description or w.name}, converted from {w.source.name}",
           f"name = {_value(w.name)}", f"description = {_value(w.description)}"]
    s = w.sim
    out += _table("[sim]", [("interval_sim", s.interval_sim_s), ("speedup", s.speedup),
                            ("quit_time", s.quit_time_s), ("seed", s.seed),
                            ("fidelity", s.fidelity), ("physics_substeps", s.physics_substeps)])
    a = w.arena
    out += _table("[arena]", [("size", [a.size_x_m, a.size_y_m]),
                              ("wall_thickness", a.wall_thickness_m),
                              ("wall_height", a.wall_height_m),
                              ("wall_colour", _colour(a.wall_colour)),
                              ("floor_colour", _colour(a.floor_colour))])
    for o in a.obstacles:
        size: list[tuple[str, Any]] = [("size", [o.size_x_m, o.size_y_m])]
        if o.shape == "cylinder":
            size = [("radius", o.radius_m)]
        elif o.shape == "polygon":
            size = [("points", [list(p) for p in o.points])]
            size += [("base", o.base_m)] if o.base_m else []
        out += _table("[[arena.obstacles]]", [("name", o.name), ("shape", o.shape), *size,
                                              ("pose", o.pose), ("height", o.height_m),
                                              ("colour", _colour(o.colour))])
    for b in w.boxes:
        out += _table("[[boxes]]", [("name", b.name), ("pose", b.pose),
                                    ("size", [b.size_x_m, b.size_y_m, b.size_z_m]),
                                    ("mass", b.mass_kg), ("colour", _colour(b.colour)),
                                    ("friction", b.friction)])
    for ob in w.objects:
        out += _table("[[objects]]", [("name", ob.name), ("pose", ob.pose),
                                      ("radius", ob.radius_m), ("height", ob.height_m),
                                      ("mass", ob.mass_kg), ("colour", _colour(ob.colour)),
                                      ("fiducial_id", ob.fiducial_id)])
    for m in w.markers:
        out += _table("[[markers]]", [("name", m.name), ("position", [m.x, m.y]),
                                      ("radius", m.radius_m), ("height", m.height_m),
                                      ("colour", _colour(m.colour))])
    for c in w.chargers:
        out += _table("[[chargers]]", [("name", c.name), ("position", [c.x, c.y]),
                                       ("radius", c.radius_m), ("colour", _colour(c.colour)),
                                       ("rate", c.rate_w), ("beacon_height", c.beacon_height_m)]
                       + ([("take", c.take_w)] if c.take_w else [])
                       + ([("footprint", [c.size_x_m, c.size_y_m]),
                           ("yaw_deg", math.degrees(c.yaw))] if c.size_x_m > 0 else []))
    if (oc := w.overhead_camera) is not None:
        out += _table("[overhead_camera]", [
            ("name", oc.name), ("position", [oc.x, oc.y]), ("height", oc.height_m),
            ("view_size", [oc.view_size_x_m, oc.view_size_y_m]),
            ("resolution", [oc.width_px, oc.height_px]),
            ("position_noise", oc.position_noise_m)])
    for r in w.robots:
        out += _robot(r)
    return "\n".join(out) + "\n"
