"""Stage `position` models and their children -> `RobotSpec`s."""

from __future__ import annotations

import math
from dataclasses import dataclass

from worlds import pioneer
from worlds.spec import (
    BlobfinderSpec,
    BodySpec,
    BumperSegment,
    BumperSpec,
    CameraSpec,
    DeviceSet,
    FiducialSpec,
    GripperSpec,
    LaserSpec,
    Mount,
    Pose,
    Position2dSpec,
    PowerSpec,
    RangerSpec,
    RobotSpec,
    SonarSpec,
)
from worlds.stage.blocks import body_outline
from worlds.stage.colour import model_colour, stage_colour
from worlds.stage.syntax import StageError, Where
from worlds.stage.tree import Reader, StageModel, Units, Warnings

#: keys every model may carry that mean nothing for a robot's simulation here
COMMON_IGNORED = frozenset({
    "gui_nose", "gui_grid", "gui_outline", "gui_move", "gui_boundary", "obstacle_return",
    "laser_return", "ranger_return", "blob_return", "fiducial_key",
    "gripper_return", "map_resolution", "stack_children", "update_interval", "watts",
    "alwayson", "ctrl", "boundary", "color_rgba", "color", "mass", "origin", "name",
    "pose", "size", "fiducial_return", "joules", "joules_capacity", "kjoules",
    "give_watts", "take_watts", "velocity_enable", "interval", "localization_origin",
})


@dataclass(frozen=True)
class RangerRole:
    """What a position model's Nth ranger became: "sonar", "laser", "ranger" or "" (none)."""

    name: str
    role: str


@dataclass(frozen=True)
class RobotOut:
    spec: RobotSpec
    rangers: tuple[RangerRole, ...]


def _mount(pose: tuple[float, float, float, float], base: Mount) -> Mount:
    """A child's pose (in its parent's frame, z above the parent's top) over its parent's."""
    x, y, z, a = pose
    c, s = math.cos(base.yaw), math.sin(base.yaw)
    return Mount(base.x + c * x - s * y, base.y + s * x + c * y, base.z + z, base.yaw + a)


def _reader(m: StageModel, units: Units, warnings: Warnings,
            extra: frozenset[str] = frozenset()) -> Reader:
    return Reader(f"{m.token} {m.name!r}", m.props, units, warnings, COMMON_IGNORED | extra)


def convert_position(m: StageModel, units: Units, warnings: Warnings) -> RobotOut:
    r = _reader(m, units, warnings)
    drive = r.string("drive", "diff")
    if drive != "diff":
        raise StageError(r.where("drive", m.where),
                         f'drive "diff" for position {m.name!r} (the simulated robots are '
                         "differential drive)", f'"{drive}"')
    x, y, _, yaw = r.pose()
    sx, sy, sz = r.size((0.44, 0.38, 0.22))
    if sx <= 0 or sy <= 0:
        raise StageError(r.where("size", m.where), f"a positive size for position {m.name!r}",
                         [sx, sy, sz])
    ox = r.numbers("origin", 4, (0.0, 0.0, 0.0, 0.0))[0] * units.length
    mass = r.number("mass", 9.0)
    body = BodySpec(length_m=sx, width_m=sy, height_m=max(sz, 0.05), offset_x_m=ox,
                    mass_kg=mass if mass > 0 else 9.0, outline=body_outline(m, r, (sx, sy)))
    loc = r.string("localization", "gps")
    if loc not in ("gps", "odom"):
        raise StageError(r.where("localization", m.where), 'localization "gps" or "odom"',
                         f'"{loc}"')
    given = r.props.get("odom_error")
    err = r.numbers("odom_error", 4, (0.03, 0.03, 0.0, 0.05), min_n=3)
    err_yaw = err[2] if given is not None and len(given.values) == 3 else err[3]  # [x y a]
    vb = r.numbers("velocity_bounds", 8, (-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -90.0, 90.0))
    ab = r.numbers("acceleration_bounds", 8, (-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -90.0, 90.0))
    vmax, wmax = vb[1] * units.length, vb[7] * units.angle
    amax, awmax = ab[1] * units.length, ab[7] * units.angle
    if min(vmax, wmax, amax, awmax) <= 0:
        raise StageError(r.where("velocity_bounds", m.where),
                         "positive upper velocity and acceleration bounds", f"{vb} / {ab}")
    position = Position2dSpec(
        max_speed_mps=vmax, max_yaw_rate_radps=wmax, accel_mps2=amax, yaw_accel_radps2=awmax,
        odom_noise_fraction=max(err[0], err[1]) if loc == "odom" else 0.0,
        odom_yaw_noise_fraction=err_yaw if loc == "odom" else 0.0)
    power = _power(r, m.where)
    top = Mount(0.0, 0.0, body.height_m, 0.0)
    devices: dict[str, object] = {"position2d": position, "power": power}
    rangers: list[RangerRole] = []
    for child in m.children:
        _device(child, top, units, warnings, devices, rangers, body)
    if devices.get("blobfinder") is not None and devices.get("camera") is None:
        devices["camera"] = devices.pop("_blob_camera")
    devices.pop("_blob_camera", None)
    fid = r.number("fiducial_return", 0.0)
    r.finish(m.where)
    spec = RobotSpec(m.name, Pose(x, y, yaw), model_colour(r, m, warnings, 0xFF0000), body,
                     DeviceSet(**devices),  # type: ignore[arg-type]
                     fiducial_id=int(fid))
    return RobotOut(spec, tuple(rangers))


def _power(r: Reader, where: Where) -> PowerSpec | None:
    if not (r.has("joules") or r.has("joules_capacity") or r.has("kjoules")):
        return None
    cap = r.number("joules_capacity", 0.0) or r.number("kjoules", 0.0) * 1000.0
    joules = r.number("joules", cap)
    cap = cap or joules
    if cap <= 0 or joules < 0:
        raise StageError(r.where("joules", r.where("joules_capacity", where)),
                         "a positive joules_capacity (or kjoules) and joules >= 0",
                         f"{cap:g} / {joules:g}")
    watts = r.number("watts", PowerSpec().idle_w)
    if watts < 0:
        raise StageError(r.where("watts", where), "watts >= 0", watts)
    return PowerSpec(capacity_j=cap, initial_fraction=min(1.0, joules / cap),
                     idle_w=watts, moving_w=0.0, sensor_w=0.0)


def _device(m: StageModel, parent: Mount, units: Units, warnings: Warnings,
            devices: dict[str, object], rangers: list[RangerRole], body: BodySpec) -> None:
    r = _reader(m, units, warnings, frozenset({"ssize", "scount", "sview"}))
    mount = _mount(r.pose(), parent)
    kind = m.kind
    if kind == "ranger":
        role = _ranger(m, r, mount, units, warnings, devices)
        rangers.append(RangerRole(m.name, role))
    elif kind == "laser":  # Stage 3
        _put(devices, "laser", _stage3_laser(m, r, mount), m, warnings)
    elif kind == "blobfinder":
        _blobfinder(m, r, mount, devices, warnings)
    elif kind == "fiducial":
        fov = r.angle("fov", math.pi)
        _put(devices, "fiducial", FiducialSpec(
            pose=mount, min_range_m=r.length("range_min", 0.0),
            max_range_m=r.length("range_max", 8.0), fov_rad=max(fov, 1e-3)), m, warnings)
        r.has("range_max_id")
    elif kind == "camera":
        w, h = r.numbers("resolution", 2, (160.0, 120.0))
        fov_h = r.numbers("fov", 2, (70.0, 40.0))[0] * units.angle
        rng = r.numbers("range", 2, (0.0, 8.0))
        r.has("pantilt")
        _put(devices, "camera", CameraSpec(pose=mount, fov_h_rad=fov_h, width_px=int(w),
                                           height_px=int(h),
                                           max_range_m=rng[1] * units.length), m, warnings)
    elif kind == "gripper":
        sx, sy, _ = r.size((0.2, 0.3, 0.2))
        r.has("paddle_size")
        r.has("paddle_state")
        r.has("autosnatch")
        _put(devices, "gripper", GripperSpec(pose=mount, width_m=max(0.1, sy * 0.7),
                                             depth_m=max(0.05, sx * 0.6)), m, warnings)
    elif kind == "bumper":
        _put(devices, "bumper", _bumper(r, units, body), m, warnings)
    else:
        warnings.once(f"child:{m.where}", f"{m.where}: {m.token} {m.name!r} on a robot is not "
                                          "simulated here; ignored")
        return
    r.finish(m.where)


def _put(devices: dict[str, object], slot: str, spec: object, m: StageModel,
         warnings: Warnings) -> None:
    if devices.get(slot) is not None:
        warnings.once(f"dup:{m.where}", f"{m.where}: a second {slot} on one robot is not "
                                        "simulated here; ignored")
        return
    devices[slot] = spec


def _stage3_laser(m: StageModel, r: Reader, mount: Mount) -> LaserSpec:
    top = r.length("range_max", 8.0)
    fov = r.angle("fov", math.pi)
    samples = int(r.number("samples", 361))
    if samples < 1 or not 0 < fov <= 2 * math.pi or top <= 0:
        raise StageError(m.where, f"laser {m.name!r} with samples >= 1, 0 < fov <= 360 deg "
                                  "and range_max > 0",
                         f"samples {samples}, fov {math.degrees(fov):g}, range_max {top:g}")
    return LaserSpec(pose=mount, min_angle_rad=-fov / 2, max_angle_rad=fov / 2,
                     samples=samples, max_range_m=top)


def _ranger(m: StageModel, r: Reader, mount: Mount, units: Units, warnings: Warnings,
            devices: dict[str, object]) -> str:
    """A ranger's sensors: one with many samples is a laser, one-sample ones a sonar array."""
    sensors: list[tuple[Mount, tuple[float, float], float, int]] = []
    for s in m.parts:
        if s.kind != "sensor":
            continue
        sr = _reader(s, units, warnings, frozenset({"color", "resolution"}))
        smount = _mount(sr.pose(), mount)
        rng = sr.numbers("range", 2, (0.0, 5.0))
        fov, samples = sr.angle("fov", math.radians(15.0)), sr.number("samples", 1)
        if samples < 1 or samples != int(samples) or not 0 < fov <= 2 * math.pi \
                or not 0 <= rng[0] < rng[1]:
            raise StageError(s.where, "a sensor with whole samples >= 1, 0 < fov <= 360 deg "
                                      "and range [min max] with 0 <= min < max",
                             f"samples {samples:g}, fov {math.degrees(fov):g}, "
                             f"range [{rng[0]:g} {rng[1]:g}]")
        sensors.append((smount, (rng[0] * units.length, rng[1] * units.length), fov,
                        int(samples)))
        sr.finish(s.where)
    count = int(r.number("scount", 0))
    if count:  # the older scount / spose[i] / sview form
        view = r.numbers("sview", 3, (0.0, 5.0, 15.0))
        for i in range(count):
            p = r.numbers(f"spose[{i}]", 3, (0.0, 0.0, 0.0))
            sensors.append((_mount((p[0] * units.length, p[1] * units.length, 0.0,
                                    p[2] * units.angle), mount),
                            (view[0] * units.length, view[1] * units.length),
                            view[2] * units.angle, 1))
    if not sensors:
        warnings.once(f"nosensor:{m.where}", f"{m.where}: ranger {m.name!r} has no sensor; "
                                             "ignored")
        return ""
    if len(sensors) == 1 and sensors[0][3] > 1:
        smount, (lo, hi), fov, samples = sensors[0]
        spec = LaserSpec(pose=smount, min_angle_rad=-fov / 2, max_angle_rad=fov / 2,
                         samples=samples, min_range_m=lo, max_range_m=hi)
        if devices.get("laser") is None:
            devices["laser"] = spec
            return "laser"
        if devices.get("ranger") is None:
            devices["ranger"] = RangerSpec(**{k: getattr(spec, k) for k in (
                "pose", "min_angle_rad", "max_angle_rad", "samples", "min_range_m",
                "max_range_m")})
            return "ranger"
    elif all(s[3] == 1 for s in sensors) and devices.get("sonar") is None:
        lo, hi = sensors[0][1]
        devices["sonar"] = SonarSpec(poses=tuple(s[0] for s in sensors), min_range_m=lo,
                                     max_range_m=hi, cone_rad=min(sensors[0][2], math.pi))
        return "sonar"
    warnings.once(f"ranger:{m.where}", f"{m.where}: ranger {m.name!r} ({len(sensors)} sensors) "
                                       "is more than this robot's sonar, laser and ranger "
                                       "slots hold; ignored")
    return ""


def _blobfinder(m: StageModel, r: Reader, mount: Mount, devices: dict[str, object],
                warnings: Warnings) -> None:
    n = int(r.number("colors_count", 0))
    raw = r.props.get("colors")
    r.has("colors")
    names = [v for v in raw.values if isinstance(v, str)] if raw is not None else []
    if n and len(names) < n:
        raise StageError(raw.where if raw else m.where, f"{n} colour names in colors",
                         len(names))
    channels = tuple(stage_colour(c, raw.where if raw else m.where, warnings)
                     for c in names[:n or len(names)])
    if not channels:
        raise StageError(m.where, f"colors_count and colors for blobfinder {m.name!r}", "none")
    w, h = r.numbers("image", 2, (80.0, 60.0))
    _put(devices, "blobfinder", BlobfinderSpec(channels=channels), m, warnings)
    devices["_blob_camera"] = CameraSpec(
        pose=mount, fov_h_rad=min(r.angle("fov", math.radians(60.0)), math.radians(170.0)),
        width_px=int(w), height_px=int(h), max_range_m=r.length("range", 12.0))


def _bumper(r: Reader, units: Units, body: BodySpec) -> BumperSpec:
    count = int(r.number("bcount", 0))
    if not count:
        return BumperSpec(pioneer.bumper_ring(body))
    length = r.length("blength", 0.1)
    segs = []
    for i in range(count):
        p = r.numbers(f"bpose[{i}]", 3, (0.0, 0.0, 0.0))
        segs.append(BumperSegment(p[0] * units.length, p[1] * units.length,
                                  p[2] * units.angle, length))
    return BumperSpec(tuple(segs))
