"""A Stage world (model tree) -> the project's `WorldSpec`, plus what Player needs by name.

Position models become robots (their children devices), models with `bitmap` become static
wall boxes (runs of dark pixels merged), `gripper_return` models become grippable objects,
`give_watts` / `take_watts` models chargers (or drains: a charger that takes), other solid
models static obstacles (one per block: a box, or the block's polygon), and models that
return nothing zones (named places, not simulated).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from worlds.polygon import is_axis_rectangle
from worlds.polygon import problem as polygon_problem
from worlds.spec import (
    ArenaSpec,
    ChargerSpec,
    ObjectSpec,
    ObstacleSpec,
    Pose,
    RobotSpec,
    SimSpec,
    WorldSpec,
)
from worlds.stage.bitmap import Rect, merge_runs, read_solid
from worlds.stage.blocks import read_block, scale_into
from worlds.stage.colour import model_colour
from worlds.stage.robots import COMMON_IGNORED, RangerRole, convert_position
from worlds.stage.syntax import Document, StageError, Where, parse_file
from worlds.stage.tree import Reader, StageModel, TreeBuilder, Units, Warnings, units_of

GLOBAL_KEYS = frozenset({"resolution", "interval_sim", "interval_real", "quit_time", "speedup",
                         "paused", "threads", "show_clock", "show_clock_interval",
                         "unit_length", "unit_angle", "name", "seed"})


@dataclass(frozen=True)
class StageWorld:
    """A converted Stage world: the spec the simulator runs and Stage's names for things."""

    spec: WorldSpec
    #: position model name -> its ranger children in Stage's order (ranger:0, ranger:1, ...)
    rangers: Mapping[str, tuple[RangerRole, ...]]
    #: names of models that do not move here (obstacles, floorplans, zones) -> poses
    fixed: Mapping[str, Pose]
    paused: bool
    warnings: tuple[str, ...]


@dataclass
class _Out:
    obstacles: list[ObstacleSpec]
    objects: list[ObjectSpec]
    chargers: list[ChargerSpec]
    robots: list[RobotSpec]
    rangers: dict[str, tuple[RangerRole, ...]]
    fixed: dict[str, Pose]
    extents: list[tuple[float, float]]  # points the arena must hold
    wall: tuple[int, float] | None = None  # colour, height of the first floorplan


def load_stage_world(path: Path | str, *, warnings: Warnings | None = None) -> StageWorld:
    """Read a Stage `.world` file; StageError (file:line, expected, found) if malformed."""
    file = Path(path)
    doc = parse_file(file)
    return convert(doc, file, warnings or Warnings())


def convert(doc: Document, file: Path, warnings: Warnings) -> StageWorld:
    globals_ = {p.key: p for p in doc.props}
    units = units_of(globals_)
    g = Reader("the world", globals_, units, warnings)
    sim = SimSpec(interval_sim_s=g.number("interval_sim", 100.0) / 1000.0,
                  speedup=g.number("speedup", 1.0), quit_time_s=g.number("quit_time", 0.0),
                  seed=int(g.number("seed", 0.0)))
    if not 0 < sim.interval_sim_s <= 10 or sim.speedup < 0 or sim.quit_time_s < 0:
        raise StageError(Where(file, 1), "interval_sim in (0, 10000] ms, speedup >= 0, "
                         "quit_time >= 0", f"{sim.interval_sim_s * 1000:g} ms, "
                         f"{sim.speedup:g}, {sim.quit_time_s:g}")
    paused = g.number("paused", 0.0) != 0.0
    g.number("resolution", 0.02)
    for k in GLOBAL_KEYS:  # accepted; those not read above have no effect here
        g.has(k)
    g.finish(Where(file, 1))
    models = TreeBuilder(doc, warnings).build()
    out = _Out([], [], [], [], {}, {}, [])
    seen: dict[str, Where] = {}
    for m in models:
        for sub in [m, *m.descendants()]:
            if sub.name in seen:
                raise StageError(sub.where, f"a model name not used before (also {seen[sub.name]})",
                                 repr(sub.name))
            seen[sub.name] = sub.where
            if "ctrl" in sub.props:
                warnings.once("ctrl", f"{sub.props['ctrl'].where}: Stage controller plugins "
                                      "(ctrl) are not run here; clients drive the robots")
        _top(m, file, units, warnings, out)
    arena = _arena(out)
    spec = WorldSpec(name=file.stem, source=file, arena=arena, sim=sim,
                     robots=tuple(out.robots), objects=tuple(out.objects),
                     chargers=tuple(out.chargers), description=f"Stage world {file.name}")
    return StageWorld(spec, out.rangers, out.fixed, paused, tuple(warnings.said))


def _top(m: StageModel, file: Path, units: Units, warnings: Warnings, out: _Out) -> None:
    if m.kind == "position":
        robot = convert_position(m, units, warnings)
        out.robots.append(robot.spec)
        out.rangers[m.name] = robot.rangers
        out.extents.append((robot.spec.pose.x, robot.spec.pose.y))
        return
    if m.kind != "model":
        warnings.once(f"top:{m.where}", f"{m.where}: a {m.kind} outside a robot is not "
                                        "simulated here; ignored")
        return
    r = Reader(f"{m.token} {m.name!r}", m.props, units, warnings, COMMON_IGNORED)
    x, y, _, yaw = r.pose()
    size = r.size((0.1, 0.1, 0.1))
    colour = model_colour(r, m, warnings, 0xC0C0C0)
    obstacle = r.number("obstacle_return", 1.0) != 0.0
    give = r.number("give_watts", 0.0)
    take = r.number("take_watts", 0.0)
    for key, watts in (("give_watts", give), ("take_watts", take)):
        if watts < 0:
            raise StageError(r.where(key, m.where), f"{key} >= 0", watts)
    grip = r.number("gripper_return", 0.0) != 0.0
    bitmap = r.string("bitmap", "")
    if bitmap:
        _floorplan(m, r, bitmap, file, (x, y, yaw), size, colour, out)
    elif give > 0 or take > 0:
        half = math.hypot(size[0], size[1]) / 2
        out.chargers.append(ChargerSpec(m.name, x, y, half + (0.35 if obstacle else 0.0),
                                        colour, give, beacon_height_m=0.0, take_w=take,
                                        size_x_m=size[0], size_y_m=size[1], yaw=yaw))
        out.fixed[m.name] = Pose(x, y, yaw)
        if obstacle:
            _solid(m, r, (x, y, yaw), size, colour, out, suffix=".body")
    elif grip:
        out.objects.append(ObjectSpec(m.name, Pose(x, y, yaw), max(size[0], size[1]) / 2,
                                      max(size[2], 0.02), r.number("mass", 0.3), colour,
                                      int(r.number("fiducial_return", 0.0))))
    elif obstacle:
        _solid(m, r, (x, y, yaw), size, colour, out)
    else:
        out.fixed[m.name] = Pose(x, y, yaw)  # a zone: a named place
    out.extents.append((x, y))
    for c in m.children:
        warnings.once(f"nested:{c.where}", f"{c.where}: {c.token} {c.name!r} inside a model "
                                           "that is not a robot is not simulated; ignored")
    r.finish(m.where)


def _place(at: tuple[float, float, float], lx: float, ly: float) -> tuple[float, float]:
    x, y, yaw = at
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + c * lx - s * ly, y + s * lx + c * ly)


def _solid(m: StageModel, r: Reader, at: tuple[float, float, float],
           size: tuple[float, float, float], colour: int, out: _Out, suffix: str = "") -> None:
    """One obstacle per block (scaled into the model's size, as Stage does), or the size box.

    A block that is a rectangle along the model's axes is a box standing on the floor; any
    other block is a polygon prism over its scaled z extents."""
    ox, oy = (v * r.units.length for v in r.numbers("origin", 4, (0.0,) * 4)[:2])
    blocks = [b for b in m.parts if b.kind == "block"]
    polys = [read_block(b, r) for b in blocks]
    out.fixed[m.name + suffix] = Pose(*at)
    if not polys:
        if size[0] > 0 and size[1] > 0:
            _block(m.name + suffix, at, ((ox, oy, size[0], size[1]), ()), (0.0, size[2]),
                   colour, out)
        return
    top = max(hi for _, (_, hi) in polys) or 1.0
    scaled = scale_into([poly for poly, _ in polys], (size[0], size[1]))
    for i, (b, (_, (lo, hi)), poly) in enumerate(zip(blocks, polys, scaled, strict=True)):
        name = m.name + suffix if len(polys) == 1 else f"{m.name}{suffix}.block{i}"
        bx = [p[0] for p in poly]
        by = [p[1] for p in poly]
        sx, sy = max(bx) - min(bx), max(by) - min(by)
        if sx <= 0 or sy <= 0:
            continue
        local = tuple(zip(bx, by, strict=True))
        box = ((min(bx) + max(bx)) / 2 + ox, (min(by) + max(by)) / 2 + oy, sx, sy)
        pts: tuple[tuple[float, float], ...] = ()
        if not is_axis_rectangle(local):
            bad = polygon_problem(local)
            if bad is not None:
                raise StageError(b.where, "a block whose points outline an area without "
                                 "crossing edges", bad)
            pts = tuple((x + ox, y + oy) for x, y in local)
        _block(name, at, (box, pts), (lo / top * size[2], hi / top * size[2]), colour, out)


def _block(name: str, at: tuple[float, float, float],
           shape: tuple[tuple[float, float, float, float], tuple[tuple[float, float], ...]],
           z: tuple[float, float], colour: int, out: _Out) -> None:
    """A box (centre, size in the model's frame) standing on the floor up to z[1], or, when
    points are given, that polygon (in the model's frame) from z[0] to z[1]."""
    (cx, cy, sx, sy), pts = shape
    if pts:
        base = max(z[0], 0.0)
        ob = ObstacleSpec.polygon(name, Pose(*at), pts, max(z[1] - base, 0.01), colour, base)
        out.obstacles.append(ob)
        out.extents.extend(ob.placed())
        return
    px, py = _place(at, cx, cy)
    out.obstacles.append(ObstacleSpec(name, Pose(px, py, at[2]), "box", sx, sy,
                                      max(z[1], 0.01), colour))
    for dx in (-sx / 2, sx / 2):
        for dy in (-sy / 2, sy / 2):
            out.extents.append(_place((px, py, at[2]), dx, dy))


def _floorplan(m: StageModel, r: Reader, bitmap: str, file: Path,
               at: tuple[float, float, float], size: tuple[float, float, float], colour: int,
               out: _Out) -> None:
    where = r.where("bitmap", m.where)
    path = where.file.parent / bitmap
    if not path.exists():
        path = file.parent / bitmap
    try:
        solid = read_solid(path)
    except OSError as exc:
        raise StageError(where, "a readable bitmap image", f'"{bitmap}" ({exc})') from None
    rows, cols = solid.shape
    if size[0] <= 0 or size[1] <= 0 or size[2] <= 0:
        raise StageError(r.where("size", m.where), "a floorplan size [x y z] > 0", size)
    px, py = size[0] / cols, size[1] / rows
    rects = merge_runs(solid)
    if r.number("boundary", 0.0):
        rects += [Rect(0, 0, 1, cols), Rect(rows - 1, 0, 1, cols), Rect(0, 0, rows, 1),
                  Rect(0, cols - 1, rows, 1)]
    for i, rect in enumerate(rects):
        cx = -size[0] / 2 + (rect.col + rect.cols / 2) * px
        cy = size[1] / 2 - (rect.row + rect.rows / 2) * py
        wx, wy = _place(at, cx, cy)
        out.obstacles.append(ObstacleSpec(f"{m.name}.wall{i}", Pose(wx, wy, at[2]), "box",
                                          rect.cols * px, rect.rows * py, size[2], colour))
    for dx in (-size[0] / 2, size[0] / 2):
        for dy in (-size[1] / 2, size[1] / 2):
            out.extents.append(_place(at, dx, dy))
    out.fixed[m.name] = Pose(*at)
    if out.wall is None:
        out.wall = (colour, size[2])


def _arena(out: _Out) -> ArenaSpec:
    """Centred on the origin and holding every floorplan corner, obstacle and model."""
    hx = max([abs(x) for x, _ in out.extents] + [0.5])
    hy = max([abs(y) for _, y in out.extents] + [0.5])
    colour, height = out.wall or (0xC0C0C0, 0.5)
    return ArenaSpec(size_x_m=2 * hx, size_y_m=2 * hy, wall_thickness_m=0.1,
                     wall_height_m=height, wall_colour=colour, floor_colour=0xE8E8E8,
                     obstacles=tuple(out.obstacles))
