"""Load and validate TOML world files into frozen WorldSpec dataclasses.

File layout (all keys optional unless noted; SI units; angles as ``<key>_deg`` or
``<key>_rad``; poses as ``[x, y, yaw_deg]``; sensor mounts as ``[x, y, z, yaw_deg]``)::

    name = "simple"                  # defaults to the file stem
    [sim]     interval_sim speedup quit_time seed fidelity physics_substeps
    [arena]   size = [sx, sy] (required) wall_thickness wall_height wall_colour floor_colour
    [[arena.obstacles]] name pose shape ("box" | "cylinder") size = [sx, sy] | radius height colour
    [[boxes]]    name pose size = [sx, sy, sz] mass colour friction
    [[objects]]  name pose radius height mass colour fiducial_id
    [[markers]]  name position = [x, y] radius height colour     (visual only)
    [[chargers]] name position = [x, y] radius colour rate beacon_height
                 take footprint = [sx, sy] yaw_deg  (a model robots touch, not a pad)
    [overhead_camera] name position height view_size resolution position_noise
    [[robots]]   name pose colour fiducial_id, then one sub-table per device:
                 body position2d sonar laser ranger camera blobfinder bumper gripper ptz power
                 fiducial (an empty table means "present, defaults")
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

from worlds import generate, pioneer
from worlds.colours import parse_colour
from worlds.errors import WorldError
from worlds.reader import Table
from worlds.spec import (
    FIDELITIES,
    ArenaSpec,
    BlobfinderSpec,
    BodySpec,
    BoxSpec,
    BumperSegment,
    BumperSpec,
    CameraSpec,
    ChargerSpec,
    DeviceSet,
    FiducialSpec,
    GripperSpec,
    LaserSpec,
    MarkerSpec,
    Mount,
    ObjectSpec,
    ObstacleSpec,
    OverheadCameraSpec,
    Position2dSpec,
    PowerSpec,
    PtzSpec,
    RangerSpec,
    RobotSpec,
    SimSpec,
    SonarSpec,
    WorldSpec,
)

WORLDS_DIR = Path(__file__).resolve().parent

# Default sensor draw (W) per device when a power table gives no sensor_w.
DEVICE_DRAW_W: dict[str, float] = {
    "sonar": 2.0,
    "laser": 20.0,
    "ranger": 10.0,
    "camera": 5.0,
    "ptz": 3.0,
    "gripper": 1.0,
    "fiducial": 2.0,
}


def world_path(name: str) -> Path:
    """The path of a bundled world by name (``"longterm"`` -> ``worlds/longterm.toml``)."""
    candidate = Path(name)
    if candidate.suffix in (".toml", ".world") and candidate.exists():
        return candidate
    path = WORLDS_DIR / f"{candidate.stem if candidate.suffix == '.toml' else name}.toml"
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in WORLDS_DIR.glob("*.toml")))
        raise FileNotFoundError(f"no world named {name!r} (bundled worlds: {known})")
    return path


def load_world(path: Path | str) -> WorldSpec:
    """Parse and validate a world file (TOML, or a Stage ``.world``); raises WorldError
    naming file, key (or line), expected, found."""
    file = Path(path)
    if file.suffix == ".world":
        from worlds.stage import load_stage_world

        return load_stage_world(file).spec
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as exc:
        raise WorldError(file, "", "a readable TOML file", str(exc)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise WorldError(file, "", "valid TOML", str(exc)) from None
    return parse_world(data, file)


def parse_world(data: dict[str, object], file: Path) -> WorldSpec:
    if "generate" in data:
        data = _generated(data, file)
    top = Table(file, "", data)
    name = top.string("name", file.stem)
    description = top.string("description", "")
    sim = _sim(top.sub("sim"))
    arena = _arena(top.sub("arena"))
    boxes = tuple(_box(t) for t in top.array_of_tables("boxes"))
    objects = tuple(_object(t) for t in top.array_of_tables("objects"))
    markers = tuple(_marker(t) for t in top.array_of_tables("markers"))
    chargers = tuple(_charger(t) for t in top.array_of_tables("chargers"))
    overhead_t = top.optional_sub("overhead_camera")
    overhead = _overhead(overhead_t, arena) if overhead_t is not None else None
    robot_tables = top.array_of_tables("robots")
    robots = tuple(_robot(t, i) for i, t in enumerate(robot_tables))
    top.finish()

    _check_unique_names(file, arena, boxes, objects, markers, chargers, robots, overhead)
    _check_inside(file, arena, "boxes", [(b.name, b.pose.x, b.pose.y) for b in boxes])
    _check_inside(file, arena, "objects", [(o.name, o.pose.x, o.pose.y) for o in objects])
    _check_inside(file, arena, "markers", [(m.name, m.x, m.y) for m in markers])
    _check_inside(file, arena, "chargers", [(c.name, c.x, c.y) for c in chargers])
    _check_inside(file, arena, "robots", [(r.name, r.pose.x, r.pose.y) for r in robots])
    return WorldSpec(
        name=name,
        source=file,
        arena=arena,
        sim=sim,
        robots=robots,
        boxes=boxes,
        objects=objects,
        markers=markers,
        chargers=chargers,
        overhead_camera=overhead,
        description=description,
    )


def _generated(data: dict[str, object], file: Path) -> dict[str, object]:
    """The data with the [generate] section expanded into tables (`worlds.generate`)."""
    sim = data.get("sim")
    seed = sim.get("seed", SimSpec().seed) if isinstance(sim, dict) else SimSpec().seed
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        seed = SimSpec().seed  # the [sim] section's own check reports it
    opts = generate.read_options(Table(file, "generate", data["generate"]), seed,
                                 lambda t: _robot(t, 0))
    return generate.expand(data, file, opts)


# ---- sections ------------------------------------------------------------------------------


def _sim(t: Table) -> SimSpec:
    d = SimSpec()
    spec = SimSpec(
        interval_sim_s=t.number("interval_sim", d.interval_sim_s, positive=True, max_value=10.0),
        speedup=t.number("speedup", d.speedup, min_value=0.0),
        quit_time_s=t.number("quit_time", d.quit_time_s, min_value=0.0),
        seed=t.integer("seed", d.seed, min_value=0),
        fidelity=t.string("fidelity", d.fidelity, choices=FIDELITIES),  # type: ignore[arg-type]
        physics_substeps=t.integer("physics_substeps", d.physics_substeps, min_value=1),
    )
    t.finish()
    return spec


def _arena(t: Table) -> ArenaSpec:
    sx, sy = t.vector("size", 2, positive=True)
    obstacles = tuple(_obstacle(o) for o in t.array_of_tables("obstacles"))
    spec = ArenaSpec(
        size_x_m=sx,
        size_y_m=sy,
        wall_thickness_m=t.number("wall_thickness", 0.1, positive=True),
        wall_height_m=t.number("wall_height", 0.5, positive=True),
        wall_colour=t.colour("wall_colour", 0xC0C0C0),
        floor_colour=t.colour("floor_colour", 0x909090),
        obstacles=obstacles,
    )
    t.finish()
    for i, o in enumerate(obstacles):
        if abs(o.pose.x) > sx / 2 or abs(o.pose.y) > sy / 2:
            raise WorldError(
                t.file, f"arena.obstacles[{i}].pose", "a position inside the arena", o.pose[:2]
            )
    return spec


def _obstacle(t: Table) -> ObstacleSpec:
    shape = t.string("shape", "box", choices=("box", "cylinder"))
    if shape == "box":
        sx, sy = t.vector("size", 2, positive=True)
    else:
        r = t.number("radius", positive=True)
        sx = sy = 2.0 * r
    spec = ObstacleSpec(
        name=t.string("name"),
        pose=t.pose("pose"),
        shape=shape,  # type: ignore[arg-type]
        size_x_m=sx,
        size_y_m=sy,
        height_m=t.number("height", 0.5, positive=True),
        colour=t.colour("colour", 0xA0A0A0),
    )
    t.finish()
    return spec


def _box(t: Table) -> BoxSpec:
    sx, sy, sz = t.vector("size", 3, positive=True)
    spec = BoxSpec(
        name=t.string("name"),
        pose=t.pose("pose"),
        size_x_m=sx,
        size_y_m=sy,
        size_z_m=sz,
        mass_kg=t.number("mass", 2.0, positive=True),
        colour=t.colour("colour", 0xD2B48C),
        friction=t.number("friction", 0.5, min_value=0.0, max_value=5.0),
    )
    t.finish()
    return spec


def _object(t: Table) -> ObjectSpec:
    spec = ObjectSpec(
        name=t.string("name"),
        pose=t.pose("pose"),
        radius_m=t.number("radius", 0.06, positive=True),
        height_m=t.number("height", 0.3, positive=True),
        mass_kg=t.number("mass", 0.3, positive=True),
        colour=t.colour("colour"),
        fiducial_id=t.integer("fiducial_id", 0, min_value=0),
    )
    t.finish()
    return spec


def _marker(t: Table) -> MarkerSpec:
    x, y = t.vector("position", 2)
    spec = MarkerSpec(
        name=t.string("name"),
        x=x,
        y=y,
        radius_m=t.number("radius", 0.1, positive=True),
        height_m=t.number("height", 0.8, positive=True),
        colour=t.colour("colour"),
    )
    t.finish()
    return spec


def _charger(t: Table) -> ChargerSpec:
    x, y = t.vector("position", 2)
    footprint = t.vector("footprint", 2, (0.0, 0.0))
    if min(footprint) < 0 or (max(footprint) > 0 and min(footprint) <= 0):
        raise t.error("footprint", "two sizes > 0 (m), or none", list(footprint))
    spec = ChargerSpec(
        name=t.string("name"),
        x=x,
        y=y,
        radius_m=t.number("radius", 0.4, positive=True),
        colour=t.colour("colour", 0x00FFFF),
        rate_w=t.number("rate", 100.0, min_value=0.0),
        beacon_height_m=t.number("beacon_height", 0.5, min_value=0.0),
        take_w=t.number("take", 0.0, min_value=0.0),
        size_x_m=footprint[0],
        size_y_m=footprint[1],
        yaw=math.radians(t.number("yaw_deg", 0.0)),
    )
    t.finish()
    return spec


def _overhead(t: Table, arena: ArenaSpec) -> OverheadCameraSpec:
    x, y = t.vector("position", 2, (0.0, 0.0))
    vx, vy = t.vector("view_size", 2, (arena.size_x_m, arena.size_y_m), positive=True)
    w, h = t.vector("resolution", 2, (640.0, 480.0), positive=True)
    spec = OverheadCameraSpec(
        name=t.string("name", "overhead"),
        x=x,
        y=y,
        height_m=t.number("height", 4.0, positive=True),
        view_size_x_m=vx,
        view_size_y_m=vy,
        width_px=int(w),
        height_px=int(h),
        position_noise_m=t.number("position_noise", 0.0, min_value=0.0),
    )
    t.finish()
    return spec


# ---- robots --------------------------------------------------------------------------------


def _robot(t: Table, index: int) -> RobotSpec:
    name = t.string("name")
    pose = t.pose("pose")
    colour = t.colour("colour", 0x404040)
    fiducial_id = t.integer("fiducial_id", index + 1, min_value=0)
    body = _body(t.sub("body"))
    position2d = _opt(t, "position2d", _position2d)
    sonar = _opt(t, "sonar", _sonar)
    laser = _opt(t, "laser", lambda s: _scanner(s, LaserSpec, pioneer.LASER_MOUNT))
    ranger = _opt(t, "ranger", lambda s: _scanner(s, RangerSpec, pioneer.LASER_MOUNT))
    camera = _opt(t, "camera", _camera)
    blobfinder = _opt(t, "blobfinder", _blobfinder)
    bumper = _opt(t, "bumper", lambda s: _bumper(s, body))
    gripper = _opt(t, "gripper", _gripper)
    ptz = _opt(t, "ptz", _ptz)
    fiducial = _opt(t, "fiducial", _fiducial)
    present = [
        n
        for n, v in (
            ("sonar", sonar), ("laser", laser), ("ranger", ranger), ("camera", camera),
            ("ptz", ptz), ("gripper", gripper), ("fiducial", fiducial),
        )
        if v is not None
    ]
    power = _opt(t, "power", lambda s: _power(s, present))
    t.finish()
    if blobfinder is not None and camera is None:
        raise t.error("blobfinder", "a [camera] table on the same robot", "blobfinder alone")
    if ptz is not None and camera is None:
        raise t.error("ptz", "a [camera] table on the same robot", "ptz alone")
    devices = DeviceSet(
        position2d=position2d,
        sonar=sonar,
        laser=laser,
        ranger=ranger,
        camera=camera,
        blobfinder=blobfinder,
        bumper=bumper,
        gripper=gripper,
        ptz=ptz,
        power=power,
        fiducial=fiducial,
    )
    return RobotSpec(name, pose, colour, body, devices, fiducial_id)


def _opt(t: Table, name: str, build):
    sub = t.optional_sub(name)
    if sub is None:
        return None
    spec = build(sub)
    sub.finish()
    return spec


def _body(t: Table) -> BodySpec:
    d = BodySpec()
    spec = BodySpec(
        length_m=t.number("length", d.length_m, positive=True),
        width_m=t.number("width", d.width_m, positive=True),
        height_m=t.number("height", d.height_m, positive=True),
        offset_x_m=t.number("offset_x", d.offset_x_m),
        mass_kg=t.number("mass", d.mass_kg, positive=True),
    )
    t.finish()
    return spec


def _position2d(t: Table) -> Position2dSpec:
    d = Position2dSpec()
    return Position2dSpec(
        max_speed_mps=t.number("max_speed", d.max_speed_mps, positive=True),
        max_yaw_rate_radps=t.angle("max_yaw_rate", d.max_yaw_rate_radps, min_rad=1e-6),
        accel_mps2=t.number("accel", d.accel_mps2, positive=True),
        yaw_accel_radps2=t.angle("yaw_accel", d.yaw_accel_radps2, min_rad=1e-6),
        odom_noise_fraction=t.number("odom_noise", 0.0, min_value=0.0, max_value=1.0),
        odom_yaw_noise_fraction=t.number("odom_yaw_noise", 0.0, min_value=0.0, max_value=1.0),
    )


def _sonar(t: Table) -> SonarSpec:
    d = SonarSpec(poses=())
    z = t.number("z", pioneer.SONAR_Z_M, min_value=0.0)
    raw = t.raw("poses", "pioneer")
    if raw == "pioneer":
        poses = tuple(Mount(m.x, m.y, z, m.yaw) for m in pioneer.sonar_ring())
    elif isinstance(raw, list) and raw:
        out = []
        for i, p in enumerate(raw):
            if (
                not isinstance(p, list)
                or len(p) != 3
                or any(isinstance(v, bool) or not isinstance(v, int | float) for v in p)
            ):
                raise t.error(f"poses[{i}]", "[x, y, yaw_deg] numbers", p)
            out.append(Mount(float(p[0]), float(p[1]), z, math.radians(p[2])))
        poses = tuple(out)
    else:
        raise t.error("poses", "'pioneer' or a non-empty array of [x, y, yaw_deg]", raw)
    min_r = t.number("min_range", d.min_range_m, min_value=0.0)
    max_r = t.number("max_range", d.max_range_m, positive=True)
    if max_r <= min_r:
        raise t.error("max_range", f"a number > min_range ({min_r:g})", max_r)
    return SonarSpec(
        poses=poses,
        min_range_m=min_r,
        max_range_m=max_r,
        cone_rad=t.angle("cone", d.cone_rad, min_rad=0.0, max_rad=math.pi),
        rays_per_transducer=t.integer("rays_per_transducer", d.rays_per_transducer, min_value=1),
    )


def _scanner(t: Table, cls, mount: Mount):
    d = cls(pose=mount)
    pose = t.mount("pose", mount)
    lo = t.angle("min_angle", d.min_angle_rad, min_rad=-math.pi, max_rad=math.pi)
    hi = t.angle("max_angle", d.max_angle_rad, min_rad=-math.pi, max_rad=math.pi)
    if hi <= lo:
        raise t.error("max_angle_deg", f"an angle > min_angle ({math.degrees(lo):g} deg)",
                      math.degrees(hi))
    samples = t.integer("samples", d.samples, min_value=1)
    min_r = t.number("min_range", d.min_range_m, min_value=0.0)
    max_r = t.number("max_range", d.max_range_m, positive=True)
    if max_r <= min_r:
        raise t.error("max_range", f"a number > min_range ({min_r:g})", max_r)
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


def _camera(t: Table) -> CameraSpec:
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


def _blobfinder(t: Table) -> BlobfinderSpec:
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


def _bumper(t: Table, body: BodySpec) -> BumperSpec:
    raw = t.raw("segments", "pioneer")
    if raw == "pioneer":
        return BumperSpec(pioneer.bumper_ring(body))
    if not isinstance(raw, list) or not raw:
        raise t.error("segments", "'pioneer' or an array of [x, y, yaw_deg, length]", raw)
    segs = []
    for i, s in enumerate(raw):
        if (
            not isinstance(s, list)
            or len(s) != 4
            or any(isinstance(v, bool) or not isinstance(v, int | float) for v in s)
            or s[3] <= 0
        ):
            raise t.error(f"segments[{i}]", "[x, y, yaw_deg, length > 0]", s)
        segs.append(BumperSegment(float(s[0]), float(s[1]), math.radians(s[2]), float(s[3])))
    return BumperSpec(tuple(segs))


def _gripper(t: Table) -> GripperSpec:
    d = GripperSpec(pose=pioneer.GRIPPER_MOUNT)
    return GripperSpec(
        pose=t.mount("pose", pioneer.GRIPPER_MOUNT),
        width_m=t.number("width", d.width_m, positive=True),
        depth_m=t.number("depth", d.depth_m, positive=True),
        max_object_radius_m=t.number("max_object_radius", d.max_object_radius_m, positive=True),
        capacity=t.integer("capacity", d.capacity, min_value=1),
        move_time_s=t.number("move_time", d.move_time_s, min_value=0.0),
    )


def _ptz(t: Table) -> PtzSpec:
    d = PtzSpec()
    spec = PtzSpec(
        pan_min_rad=t.angle("pan_min", d.pan_min_rad),
        pan_max_rad=t.angle("pan_max", d.pan_max_rad),
        tilt_min_rad=t.angle("tilt_min", d.tilt_min_rad),
        tilt_max_rad=t.angle("tilt_max", d.tilt_max_rad),
        zoom_min_rad=t.angle("zoom_min", d.zoom_min_rad, min_rad=1e-3),
        zoom_max_rad=t.angle("zoom_max", d.zoom_max_rad, max_rad=math.radians(170.0)),
        pan_speed_radps=t.angle("pan_speed", d.pan_speed_radps, min_rad=1e-6),
        tilt_speed_radps=t.angle("tilt_speed", d.tilt_speed_radps, min_rad=1e-6),
        zoom_speed_radps=t.angle("zoom_speed", d.zoom_speed_radps, min_rad=1e-6),
    )
    for lo, hi, key in (
        (spec.pan_min_rad, spec.pan_max_rad, "pan_max_deg"),
        (spec.tilt_min_rad, spec.tilt_max_rad, "tilt_max_deg"),
        (spec.zoom_min_rad, spec.zoom_max_rad, "zoom_max_deg"),
    ):
        if hi < lo:
            raise t.error(key, f"an angle >= {math.degrees(lo):g} deg", math.degrees(hi))
    return spec


def _power(t: Table, devices: list[str]) -> PowerSpec:
    d = PowerSpec()
    default_sensor_w = sum(DEVICE_DRAW_W.get(n, 0.0) for n in devices)
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


def _fiducial(t: Table) -> FiducialSpec:
    d = FiducialSpec(pose=pioneer.FIDUCIAL_MOUNT)
    return FiducialSpec(
        pose=t.mount("pose", pioneer.FIDUCIAL_MOUNT),
        min_range_m=t.number("min_range", d.min_range_m, min_value=0.0),
        max_range_m=t.number("max_range", d.max_range_m, positive=True),
        fov_rad=t.angle("fov", d.fov_rad, min_rad=1e-3, max_rad=2 * math.pi),
    )


# ---- cross-checks --------------------------------------------------------------------------


def _check_unique_names(file: Path, arena, boxes, objects, markers, chargers, robots,
                        overhead) -> None:
    seen: dict[str, str] = {}
    groups = [
        ("arena.obstacles", [o.name for o in arena.obstacles]),
        ("boxes", [b.name for b in boxes]),
        ("objects", [o.name for o in objects]),
        ("markers", [m.name for m in markers]),
        ("chargers", [c.name for c in chargers]),
        ("robots", [r.name for r in robots]),
        ("overhead_camera", [overhead.name] if overhead is not None else []),
    ]
    for section, names in groups:
        for i, n in enumerate(names):
            key = f"{section}[{i}].name" if section != "overhead_camera" else f"{section}.name"
            if not n:
                raise WorldError(file, key, "a non-empty name", n)
            if n in seen:
                raise WorldError(file, key, f"a name unique in the world (also {seen[n]})", n)
            seen[n] = key


def _check_inside(file: Path, arena: ArenaSpec, section: str,
                  items: list[tuple[str, float, float]]) -> None:
    key = "pose" if section in ("boxes", "objects", "robots") else "position"
    for i, (_, x, y) in enumerate(items):
        if abs(x) > arena.half_x_m or abs(y) > arena.half_y_m:
            raise WorldError(
                file,
                f"{section}[{i}].{key}",
                f"a position inside the {arena.size_x_m:g} x {arena.size_y_m:g} m arena "
                "(centred on the origin)",
                [x, y],
            )
