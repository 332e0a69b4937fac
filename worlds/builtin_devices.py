"""The built-in device kinds, declared for `worlds.device_kinds`: their world-file tables.

Their specs are the typed slots of `worlds.spec.DeviceSet`. The kinds whose parameters are
all scalar keys are read and written from their `param` fields alone; the others (sonar poses,
scanner fans, camera resolution, blobfinder channels, bumper segments, the battery's
defaults and cross-checks) give their own reader and writer here. The order of the
declarations is `DEVICE_NAMES`'s.
"""

from __future__ import annotations

import math
from typing import Any

from worlds import pioneer
from worlds.colours import parse_colour
from worlds.device_kinds import RobotContext, declare_device, device_kinds, read_params
from worlds.params import param_items
from worlds.reader import Table
from worlds.spec import (
    BlobfinderSpec,
    BumperSegment,
    BumperSpec,
    CameraSpec,
    FiducialSpec,
    GripperSpec,
    LaserSpec,
    Mount,
    Position2dSpec,
    PowerSpec,
    PtzSpec,
    RangerSpec,
    ScanSpec,
    SonarSpec,
)


def _colour(c: int) -> str:
    return f"#{c:06x}"


def _sonar(t: Table, ctx: RobotContext) -> SonarSpec:
    d = SonarSpec(poses=())
    z = t.number("z", pioneer.SONAR_Z_M, min_value=0.0)
    raw = t.raw("poses", "pioneer")
    if raw == "pioneer":
        poses = tuple(Mount(m.x, m.y, z, m.yaw) for m in pioneer.sonar_ring())
    elif isinstance(raw, list) and raw:
        out = []
        for i, p in enumerate(raw):
            if not _numbers(p, 3):
                raise t.error(f"poses[{i}]", "[x, y, yaw_deg] numbers", p)
            out.append(Mount(float(p[0]), float(p[1]), z, math.radians(p[2])))
        poses = tuple(out)
    else:
        raise t.error("poses", "'pioneer' or a non-empty array of [x, y, yaw_deg]", raw)
    min_r, max_r = _range_limits(t, d.min_range_m, d.max_range_m)
    return SonarSpec(
        poses=poses,
        min_range_m=min_r,
        max_range_m=max_r,
        cone_rad=t.angle("cone", d.cone_rad, min_rad=0.0, max_rad=math.pi),
        rays_per_transducer=t.integer("rays_per_transducer", d.rays_per_transducer, min_value=1),
    )


def _numbers(value: Any, n: int) -> bool:
    """Is `value` an array of exactly `n` numbers (booleans are not numbers here)?"""
    return isinstance(value, list) and len(value) == n and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value)


def _range_limits(t: Table, min_default: float, max_default: float) -> tuple[float, float]:
    """A ranging device's `min_range` and `max_range` (metres), the first below the second."""
    min_r = t.number("min_range", min_default, min_value=0.0)
    max_r = t.number("max_range", max_default, positive=True)
    if max_r <= min_r:
        raise t.error("max_range", f"a number > min_range ({min_r:g})", max_r)
    return min_r, max_r


def _sonar_items(s: SonarSpec) -> list[tuple[str, Any]]:
    z = s.poses[0].z if s.poses else 0.0
    return [("z", z), ("poses", [[m.x, m.y, math.degrees(m.yaw)] for m in s.poses]),
            ("min_range", s.min_range_m), ("max_range", s.max_range_m), ("cone_rad", s.cone_rad),
            ("rays_per_transducer", s.rays_per_transducer)]


def _scanner(t: Table, cls: type[ScanSpec], mount: Mount) -> Any:
    d = cls(pose=mount)
    pose = t.mount("pose", mount)
    lo = t.angle("min_angle", d.min_angle_rad, min_rad=-math.pi, max_rad=math.pi)
    hi = t.angle("max_angle", d.max_angle_rad, min_rad=-math.pi, max_rad=math.pi)
    if hi <= lo:
        raise t.error("max_angle_deg", f"an angle > min_angle ({math.degrees(lo):g} deg)",
                      math.degrees(hi))
    samples = t.integer("samples", d.samples, min_value=1)
    min_r, max_r = _range_limits(t, d.min_range_m, d.max_range_m)
    return cls(
        pose=pose,
        min_angle_rad=lo,
        max_angle_rad=hi,
        samples=samples,
        min_range_m=min_r,
        max_range_m=max_r,
        range_res_m=t.number("range_res", d.range_res_m, positive=True),
        frequency_hz=t.number("frequency", d.frequency_hz, positive=True),
    )


def _scan_items(sc: ScanSpec) -> list[tuple[str, Any]]:
    return [("pose", sc.pose), ("min_angle_rad", sc.min_angle_rad),
            ("max_angle_rad", sc.max_angle_rad), ("samples", sc.samples),
            ("min_range", sc.min_range_m), ("max_range", sc.max_range_m),
            ("range_res", sc.range_res_m), ("frequency", sc.frequency_hz)]


def _camera(t: Table, ctx: RobotContext) -> CameraSpec:
    d = CameraSpec(pose=pioneer.CAMERA_MOUNT)
    w, h = t.vector("resolution", 2, (d.width_px, d.height_px), positive=True)
    if w != int(w) or h != int(h):
        raise t.error("resolution", "whole pixel counts", [w, h])
    return CameraSpec(
        pose=t.mount("pose", pioneer.CAMERA_MOUNT),
        tilt_rad=t.angle("tilt", d.tilt_rad, min_rad=-math.pi / 2, max_rad=math.pi / 2),
        fov_h_rad=t.angle("fov", d.fov_h_rad, min_rad=math.radians(1.0),
                          max_rad=math.radians(170.0)),
        width_px=int(w),
        height_px=int(h),
        max_range_m=t.number("max_range", d.max_range_m, positive=True),
    )


def _camera_items(c: CameraSpec) -> list[tuple[str, Any]]:
    return [("pose", c.pose), ("tilt_rad", c.tilt_rad), ("fov_rad", c.fov_h_rad),
            ("resolution", [c.width_px, c.height_px]), ("max_range", c.max_range_m)]


def _blobfinder(t: Table, ctx: RobotContext) -> BlobfinderSpec:
    raw = t.raw("channels")
    if not isinstance(raw, list) or not raw:
        raise t.error("channels", "a non-empty array of colours", raw)
    channels = []
    for i, c in enumerate(raw):
        try:
            channels.append(parse_colour(c))
        except ValueError:
            raise t.error(f"channels[{i}]", "a colour", c) from None
    d = BlobfinderSpec(channels=())
    return BlobfinderSpec(
        channels=tuple(channels),
        min_area_px=t.integer("min_area", d.min_area_px, min_value=1),
        colour_tolerance=t.integer("colour_tolerance", d.colour_tolerance, min_value=0),
    )


def _blobfinder_items(bf: BlobfinderSpec) -> list[tuple[str, Any]]:
    return [("channels", [_colour(x) for x in bf.channels]), ("min_area", bf.min_area_px),
            ("colour_tolerance", bf.colour_tolerance)]


def _bumper(t: Table, ctx: RobotContext) -> BumperSpec:
    raw = t.raw("segments", "pioneer")
    if raw == "pioneer":
        return BumperSpec(pioneer.bumper_ring(ctx.body))
    if not isinstance(raw, list) or not raw:
        raise t.error("segments", "'pioneer' or an array of [x, y, yaw_deg, length]", raw)
    segs = []
    for i, s in enumerate(raw):
        if not _numbers(s, 4) or s[3] <= 0:
            raise t.error(f"segments[{i}]", "[x, y, yaw_deg, length > 0]", s)
        segs.append(BumperSegment(float(s[0]), float(s[1]), math.radians(s[2]), float(s[3])))
    return BumperSpec(tuple(segs))


def _bumper_items(bu: BumperSpec) -> list[tuple[str, Any]]:
    return [("segments", [[g.x, g.y, math.degrees(g.yaw), g.length_m] for g in bu.segments])]


def _ptz(t: Table, ctx: RobotContext) -> PtzSpec:
    spec: PtzSpec = read_params(PtzSpec, t)
    for lo, hi, key in (
        (spec.pan_min_rad, spec.pan_max_rad, "pan_max_deg"),
        (spec.tilt_min_rad, spec.tilt_max_rad, "tilt_max_deg"),
        (spec.zoom_min_rad, spec.zoom_max_rad, "zoom_max_deg"),
    ):
        if hi < lo:
            raise t.error(key, f"an angle >= {math.degrees(lo):g} deg", math.degrees(hi))
    return spec


def _power(t: Table, ctx: RobotContext) -> PowerSpec:
    d = PowerSpec()
    kinds = device_kinds()
    default_sensor_w = sum(kinds[n].draw_w for n in ctx.present)
    flat = t.number("flat_fraction", d.flat_fraction, min_value=0.0, max_value=1.0)
    resume = t.number("resume_fraction", max(d.resume_fraction, flat), min_value=0.0,
                      max_value=1.0)
    if resume < flat:
        raise t.error("resume_fraction", f"a number >= flat_fraction ({flat:g})", resume)
    v_full = t.number("volts_full", d.volts_full, positive=True)
    v_empty = t.number("volts_empty", d.volts_empty, min_value=0.0)
    if v_empty >= v_full:
        raise t.error("volts_empty", f"a number < volts_full ({v_full:g})", v_empty)
    return PowerSpec(
        capacity_j=t.number("capacity", d.capacity_j, positive=True),
        initial_fraction=t.number("initial_fraction", d.initial_fraction, min_value=0.0,
                                  max_value=1.0),
        volts_full=v_full,
        volts_empty=v_empty,
        idle_w=t.number("idle_draw", d.idle_w, min_value=0.0),
        moving_w=t.number("moving_draw", d.moving_w, min_value=0.0),
        sensor_w=t.number("sensor_draw", default_sensor_w, min_value=0.0),
        flat_fraction=flat,
        resume_fraction=resume,
    )


declare_device("position2d", doc="differential drive and odometry")(Position2dSpec)
declare_device("sonar", doc="a ring of sonar transducers", draw_w=2.0, read=_sonar,
               write=_sonar_items)(SonarSpec)
declare_device("laser", doc="a scanning laser (SICK LMS200 by default)", draw_w=20.0,
               read=lambda t, ctx: _scanner(t, LaserSpec, pioneer.LASER_MOUNT),
               write=_scan_items)(LaserSpec)
declare_device("ranger", doc="a scanning ranger (Player ranger interface)", draw_w=10.0,
               read=lambda t, ctx: _scanner(t, RangerSpec, pioneer.LASER_MOUNT),
               write=_scan_items)(RangerSpec)
declare_device("camera", doc="a forward colour camera", draw_w=5.0, read=_camera,
               write=_camera_items)(CameraSpec)
declare_device("blobfinder", doc="colour blobs in the camera's image", needs=("camera",),
               read=_blobfinder, write=_blobfinder_items)(BlobfinderSpec)
declare_device("bumper", doc="bumper panels", read=_bumper, write=_bumper_items)(BumperSpec)
declare_device("gripper", doc="a Pioneer paddle gripper", draw_w=1.0,
               read=lambda t, ctx: read_params(GripperSpec, t, pose=pioneer.GRIPPER_MOUNT)
               )(GripperSpec)
declare_device("ptz", doc="a pan-tilt-zoom head for the camera", draw_w=3.0, needs=("camera",),
               read=_ptz)(PtzSpec)
declare_device("power", doc="the battery", late=True, read=_power, write=param_items)(PowerSpec)
declare_device("fiducial", doc="a fiducial (beacon id) detector", draw_w=2.0,
               read=lambda t, ctx: read_params(FiducialSpec, t, pose=pioneer.FIDUCIAL_MOUNT)
               )(FiducialSpec)
