"""A `WorldSpec` written back as a TOML world file that `load_world` reads to the same spec.

Angles are written in radians (`*_rad` keys, poses as tables) so nothing is lost on the way
round; colours as `#rrggbb`. Used by `murdoch world convert X.world > x.toml`.
"""

from __future__ import annotations

import math
from typing import Any

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
    d = r.devices
    out = _table("[[robots]]", [("name", r.name), ("pose", r.pose), ("colour", _colour(r.colour)),
                                ("fiducial_id", r.fiducial_id)])
    b = r.body
    out += _table("[robots.body]", [("length", b.length_m), ("width", b.width_m),
                                    ("height", b.height_m), ("offset_x", b.offset_x_m),
                                    ("mass", b.mass_kg)])
    if (p := d.position2d) is not None:
        out += _table("[robots.position2d]", [
            ("max_speed", p.max_speed_mps), ("max_yaw_rate_rad", p.max_yaw_rate_radps),
            ("accel", p.accel_mps2), ("yaw_accel_rad", p.yaw_accel_radps2),
            ("odom_noise", p.odom_noise_fraction), ("odom_yaw_noise", p.odom_yaw_noise_fraction)])
    if (s := d.sonar) is not None:
        z = s.poses[0].z if s.poses else 0.0
        out += _table("[robots.sonar]", [
            ("z", z), ("poses", [[m.x, m.y, math.degrees(m.yaw)] for m in s.poses]),
            ("min_range", s.min_range_m), ("max_range", s.max_range_m), ("cone_rad", s.cone_rad),
            ("rays_per_transducer", s.rays_per_transducer)])
    for name in ("laser", "ranger"):
        if (sc := getattr(d, name)) is not None:
            out += _table(f"[robots.{name}]", [
                ("pose", sc.pose), ("min_angle_rad", sc.min_angle_rad),
                ("max_angle_rad", sc.max_angle_rad), ("samples", sc.samples),
                ("min_range", sc.min_range_m), ("max_range", sc.max_range_m),
                ("range_res", sc.range_res_m), ("frequency", sc.frequency_hz)])
    if (c := d.camera) is not None:
        out += _table("[robots.camera]", [
            ("pose", c.pose), ("tilt_rad", c.tilt_rad), ("fov_rad", c.fov_h_rad),
            ("resolution", [c.width_px, c.height_px]), ("max_range", c.max_range_m)])
    if (bf := d.blobfinder) is not None:
        out += _table("[robots.blobfinder]", [
            ("channels", [_colour(x) for x in bf.channels]), ("min_area", bf.min_area_px),
            ("colour_tolerance", bf.colour_tolerance)])
    if (bu := d.bumper) is not None:
        out += _table("[robots.bumper]", [("segments", [
            [g.x, g.y, math.degrees(g.yaw), g.length_m] for g in bu.segments])])
    if (g := d.gripper) is not None:
        out += _table("[robots.gripper]", [
            ("pose", g.pose), ("width", g.width_m), ("depth", g.depth_m),
            ("max_object_radius", g.max_object_radius_m), ("capacity", g.capacity),
            ("move_time", g.move_time_s)])
    if (pt := d.ptz) is not None:
        out += _table("[robots.ptz]", [(f"{k.removesuffix('_radps').removesuffix('_rad')}_rad",
                                        getattr(pt, k)) for k in pt.__dataclass_fields__])
    if (pw := d.power) is not None:
        out += _table("[robots.power]", [
            ("capacity", pw.capacity_j), ("initial_fraction", pw.initial_fraction),
            ("volts_full", pw.volts_full), ("volts_empty", pw.volts_empty),
            ("idle_draw", pw.idle_w), ("moving_draw", pw.moving_w),
            ("sensor_draw", pw.sensor_w), ("flat_fraction", pw.flat_fraction),
            ("resume_fraction", pw.resume_fraction)])
    if (f := d.fiducial) is not None:
        out += _table("[robots.fiducial]", [
            ("pose", f.pose), ("min_range", f.min_range_m), ("max_range", f.max_range_m),
            ("fov_rad", f.fov_rad)])
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
        size = [("size", [o.size_x_m, o.size_y_m])] if o.shape == "box" else [
            ("radius", o.radius_m)]
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
