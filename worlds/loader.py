"""Load and validate TOML world files into frozen WorldSpec dataclasses.

File layout (all keys optional unless noted; SI units; angles as ``<key>_deg`` or
``<key>_rad``; poses as ``[x, y, yaw_deg]``; sensor mounts as ``[x, y, z, yaw_deg]``)::

    name = "simple"                  # defaults to the file stem
    [sim]     interval_sim speedup quit_time seed fidelity physics_substeps
    [arena]   size = [sx, sy] (required) wall_thickness wall_height wall_colour floor_colour
    [[arena.obstacles]] name pose shape ("box" | "cylinder" | "polygon") size = [sx, sy] | radius
                 | points = [[x, y], ...] (in the obstacle's frame) height colour base (polygon)
    [[boxes]]    name pose size = [sx, sy, sz] mass colour friction
    [[objects]]  name pose radius height mass colour fiducial_id
    [[markers]]  name position = [x, y] radius height colour     (visual only)
    [[chargers]] name position = [x, y] radius colour rate beacon_height
                 take footprint = [sx, sy] yaw_deg  (a model robots touch, not a pad)
    [overhead_camera] name position height view_size resolution position_noise
    [[robots]]   name pose colour fiducial_id, body (length width height offset_x mass
                 outline = [[x, y], ...]: a convex footprint about the body's centre), then one
                 sub-table per device kind
                 (`worlds.device_kinds`: position2d sonar laser ranger camera blobfinder
                 bumper gripper ptz power fiducial, and those of `worlds.devices`; an empty
                 table means "present, defaults")
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

from worlds import generate
from worlds.device_kinds import RobotContext, device_kinds
from worlds.errors import WorldError
from worlds.polygon import convex_hull, is_convex
from worlds.polygon import problem as polygon_problem
from worlds.reader import Table
from worlds.spec import (
    DEVICE_NAMES,
    FIDELITIES,
    ArenaSpec,
    BodySpec,
    BoxSpec,
    ChargerSpec,
    DeviceSet,
    MarkerSpec,
    ObjectSpec,
    ObstacleSpec,
    OverheadCameraSpec,
    RobotSpec,
    SimSpec,
    WorldSpec,
)

WORLDS_DIR = Path(__file__).resolve().parent


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
    shape = t.string("shape", "box", choices=("box", "cylinder", "polygon"))
    if shape == "polygon":
        spec = ObstacleSpec.polygon(
            t.string("name"), t.pose("pose"), _points(t, "points"),
            t.number("height", 0.5, positive=True), t.colour("colour", 0xA0A0A0),
            t.number("base", 0.0, min_value=0.0))
        t.finish()
        return spec
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


def _points(t: Table, name: str) -> tuple[tuple[float, float], ...]:
    """A simple polygon: ``[[x, y], ...]``, 3 points or more, edges not crossing, some area."""
    value = t.raw(name)
    expected = "[[x, y], ...]: 3 or more points outlining an area without crossing edges"
    if not isinstance(value, list) or not all(
            isinstance(p, list) and len(p) == 2 and all(
                not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)
                for v in p) for p in value):
        raise t.error(name, expected, value)
    pts = tuple((float(p[0]), float(p[1])) for p in value)
    bad = polygon_problem(pts)
    if bad is not None:
        raise t.error(name, expected, f"{bad} in {value}")
    return pts


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
    kinds = device_kinds()
    found: dict[str, object] = {}
    for kind in [k for k in kinds.values() if not k.late] + [
            k for k in kinds.values() if k.late]:
        sub = t.optional_sub(kind.name)
        if sub is not None:
            found[kind.name] = kind.read_table(sub, RobotContext(body, tuple(found)))
            sub.finish()
    t.finish()
    for kind in kinds.values():
        for need in kind.needs:
            if kind.name in found and need not in found:
                raise t.error(kind.name, f"a [{need}] table on the same robot",
                              f"{kind.name} alone")
    built_in = {n: found.get(n) for n in DEVICE_NAMES}
    extra = tuple((n, found[n]) for n in kinds if n in found and n not in built_in)
    devices = DeviceSet(**built_in, extra=extra)  # type: ignore[arg-type]
    return RobotSpec(name, pose, colour, body, devices, fiducial_id)


def _body(t: Table) -> BodySpec:
    d = BodySpec()
    outline: tuple[tuple[float, float], ...] = ()
    length, width = d.length_m, d.width_m
    if t.has("outline"):
        outline = _points(t, "outline")
        if not is_convex(outline):
            raise t.error("outline", "a convex outline", outline)
        outline = convex_hull(outline)  # anticlockwise, without straight-through corners
        length = 2 * max(abs(x) for x, _ in outline)
        width = 2 * max(abs(y) for _, y in outline)
    spec = BodySpec(
        length_m=t.number("length", length, positive=True),
        width_m=t.number("width", width, positive=True),
        height_m=t.number("height", d.height_m, positive=True),
        offset_x_m=t.number("offset_x", d.offset_x_m),
        mass_kg=t.number("mass", d.mass_kg, positive=True),
        outline=outline,
    )
    t.finish()
    if any(abs(x) > spec.length_m / 2 + 1e-9 or abs(y) > spec.width_m / 2 + 1e-9
           for x, y in outline):
        raise t.error("outline", f"points within the body's length and width "
                      f"({spec.length_m:g} x {spec.width_m:g} m about its centre)", outline)
    return spec


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
