"""Stage blocks as polygons: a laser served over real TCP reads a triangular and an L-shaped
block obstacle, and a robot whose blocks make a dart-shaped body, where ray geometry on their
polygons says, not on their bounding boxes; the render fidelity (PyBullet's rays) agrees, a
robot drives past the box's corner up to the triangle's slanted side, and the dart's own
laser does not see its body.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from sibling import load_sibling

from player_server.client import LaserProxy
from player_server.sim import Simulation
from worlds.stage import load_stage_world

INCLUDE = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "include"
LASER = (0.2, 0.0)  # the laser's mount ahead of the robot's origin (sick.inc)

# A wedge pointing at the robot: apex (2, 0), back corners (4, -1) and (4, 1). Its block is
# drawn in its own units ([0 10] x [0 4]) and scaled into the model's 2 x 2 m size.
TRIANGLE = ((2.0, 0.0), (4.0, -1.0), (4.0, 1.0))
# An L on the robot's left, its notch facing the robot: x 1..3, y 2..4, less x 1.6..3, y 2..3.4
L_SHAPE = ((1.0, 2.0), (1.6, 2.0), (1.6, 3.4), (3.0, 3.4), (3.0, 4.0), (1.0, 4.0))
# A robot at (1.5, -2.5) facing +y whose blocks make a dart 0.8 m long and 0.6 m wide: its tip
# (0.4, 0) in its own frame points at the robot with the laser.
DART = ((1.8, -2.9), (1.5, -2.1), (1.2, -2.9))
# A post inside the dart's size box, beside its slanted side: (0.3, 0.25) in the dart's frame.
POST = ((1.22, -2.23), (1.28, -2.23), (1.28, -2.17), (1.22, -2.17))
POLYGONS = [TRIANGLE, L_SHAPE, DART, POST]

WORLD = f"""
include "{INCLUDE}/pioneer.inc"
include "{INCLUDE}/sick.inc"
interval_sim 100

pioneer2dx( name "robot1" pose [ 0 0 0 0 ] sicklaser() )
model( name "wedge" pose [ 3 0 0 0 ] size [ 2 2 0.5 ] color "gray"
  block( points 3 point[0] [ 0 2 ] point[1] [ 10 0 ] point[2] [ 10 4 ] z [ 0 1 ] ) )
model( name "ell" pose [ 2 3 0 0 ] size [ 2 2 0.5 ] color "gray"
  block( points 6 point[0] [ 0 0 ] point[1] [ 0.6 0 ] point[2] [ 0.6 1.4 ] point[3] [ 2 1.4 ]
         point[4] [ 2 2 ] point[5] [ 0 2 ] z [ 0 1 ] ) )
position( name "dart" pose [ 1.5 -2.5 0 90 ] size [ 0.8 0.6 0.3 ] origin [ 0 0 0 0 ]
  block( points 3 point[0] [ 0 0 ] point[1] [ 4 1 ] point[2] [ 0 2 ] z [ 0 1 ] )
  sicklaser( pose [ 0 0 0.03 0 ] ) )
model( name "post" pose [ 1.25 -2.2 0 0 ] size [ 0.06 0.06 0.5 ] color "gray" )
"""

CFG = """
driver ( name "stage" model "robot1" provides [ "7301:position2d:0" "7301:ranger:1" ]
         worldfile "blocks.world" )
driver ( name "rangertolaser" requires [ "7301:ranger:1" ] provides [ "7301:laser:0" ] )
"""


@pytest.fixture(scope="module")
def cfg(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("blocks")
    (d / "blocks.world").write_text(WORLD)
    (d / "blocks.cfg").write_text(CFG)
    return d / "blocks.cfg"


_stage = load_sibling(__file__, "stage_serving.py")


def _ray(origin: tuple[float, float], a: float, polygons: list[tuple[tuple[float, float], ...]],
         max_range: float) -> float:
    """Nearest crossing of a polygon's edge along the ray, in float64."""
    ox, oy = origin
    dx, dy = math.cos(a), math.sin(a)
    best = max_range
    for pts in polygons:
        for (x1, y1), (x2, y2) in zip(pts, pts[1:] + pts[:1], strict=True):
            ex, ey = x2 - x1, y2 - y1
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            t = ((x1 - ox) * ey - (y1 - oy) * ex) / den
            u = ((x1 - ox) * dy - (y1 - oy) * dx) / den
            if t > 0 and 0 <= u <= 1:
                best = min(best, t)
    return best


def _box(pts: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    return ((min(xs), min(ys)), (max(xs), min(ys)), (max(xs), max(ys)), (min(xs), max(ys)))


def _grazes(a: float, reach: float) -> bool:
    """Does the ray pass within 1 cm of a polygon's corner before `reach` (where a few
    millimetres of collision margin decide whether it hits)?"""
    dx, dy = math.cos(a), math.sin(a)
    for x, y in TRIANGLE + L_SHAPE + DART + POST:
        along = (x - LASER[0]) * dx + (y - LASER[1]) * dy
        if 0 < along <= reach + 0.01 and abs((y - LASER[1]) * dx - (x - LASER[0]) * dy) < 0.01:
            return True
    return False


def _check(ranges: list[float], angles: np.ndarray, max_range: float) -> int:
    """Each reading where the polygons put it; how many rays a box would put elsewhere."""
    differ = 0
    for r, a in zip(ranges, angles, strict=True):
        want = _ray(LASER, float(a), POLYGONS, max_range)
        boxed = _ray(LASER, float(a), [_box(p) for p in POLYGONS], max_range)
        if want >= max_range - 0.01 or _grazes(float(a), want):
            continue  # the arena's wall, not a block; or a ray past a corner
        assert r == pytest.approx(want, abs=0.03), (math.degrees(a), r, want, boxed)
        if abs(boxed - want) > 0.3:
            differ += 1
    return differ


def test_laser_reads_the_block_polygons_over_tcp(cfg: Path) -> None:
    with _stage.robot1(cfg) as cl:
        laser = cl.subscribe(LaserProxy)
        for _ in range(3):
            cl.read()
        scan = laser.scan
        assert scan is not None
        angles = scan.min_angle + scan.resolution * np.arange(len(scan.ranges))
        # The arena ends just past the blocks: only rays that meet a block are checked.
        differ = _check(list(scan.ranges), angles, scan.max_range)
        assert differ > 40  # the wedge's slanted sides and the L's notch
        # Straight ahead: the wedge's apex; 10 degrees up: its slanted side, a metre behind
        # where its bounding box's face would be.
        ahead = int(np.argmin(np.abs(angles)))
        assert scan.ranges[ahead] == pytest.approx(1.8, abs=0.03)
        up = int(np.argmin(np.abs(angles - math.radians(10.0))))
        assert scan.ranges[up] == pytest.approx(_ray(LASER, float(angles[up]), [TRIANGLE], 8.0),
                                                abs=0.03)
        assert scan.ranges[up] > 1.8 / math.cos(angles[up]) + 0.8


def test_render_fidelity_and_physics_meet_the_polygons(cfg: Path) -> None:
    spec = load_stage_world(cfg.parent / "blocks.world").spec
    assert {o.name: o.shape for o in spec.arena.obstacles} == {
        "wedge": "polygon", "ell": "polygon", "post": "box"}
    dart = spec.robots[1].body
    assert (dart.length_m, dart.width_m, dart.offset_x_m) == (0.8, 0.6, 0.0)
    assert dart.outline == ((-0.4, -0.3), (0.4, 0.0), (-0.4, 0.3))
    render = dataclasses.replace(spec, sim=dataclasses.replace(spec.sim, fidelity="render"))
    with Simulation(render, seed=1) as sim:
        sim.step()
        ranges = sim.range_model.reading("robot1", "laser")
        laser = spec.robots[0].devices.laser
        assert laser is not None
        angles = np.linspace(laser.min_angle_rad, laser.max_angle_rad, laser.samples)
        assert _check(list(ranges), angles, laser.max_range_m) > 40
    # Driving along y = 0.6: the wedge's box would stop the robot's nose at x = 2; its
    # slanted side (y = (x - 2) / 2) lets the robot on, sliding along it, never into it.
    body = spec.robots[0].body
    with Simulation(spec, seed=1) as sim:
        sim.set_pose("robot1", 0.0, 0.6, 0.0)
        sim.set_velocity("robot1", 0.4, 0.0)
        furthest = 0.0
        for _ in range(100):
            sim.step()
            x, y, yaw = sim.get_pose("robot1")
            furthest = max(furthest, x)
            c, s = math.cos(yaw), math.sin(yaw)
            for lx in (body.offset_x_m - body.length_m / 2, body.offset_x_m + body.length_m / 2):
                for ly in (-body.width_m / 2, body.width_m / 2):
                    cx, cy = x + c * lx - s * ly, y + s * lx + c * ly
                    if 2.0 <= cx <= 4.0:
                        assert cy >= (cx - 2.0) / 2 - 0.03, (x, y, yaw, cx, cy)
        assert furthest > 2.4


def test_a_laser_inside_a_dart_body_sees_out_of_it(cfg: Path) -> None:
    """The dart's laser sits at its body's centre: no ray meets its own body (0.15 to 0.5 m
    from the laser), the post beside its slanted side (inside its size box) is seen; straight
    ahead (+y) it reads the L's lower edge, 4.5 m away, and to its right (+x) the arena's
    wall at x = 4."""
    spec = load_stage_world(cfg.parent / "blocks.world").spec
    with Simulation(spec, seed=1) as sim:
        sim.step()
        ranges = sim.range_model.reading("dart", "laser")
        near = np.flatnonzero(np.asarray(ranges) < 0.5)  # the post only, ~40 degrees left
        assert near.size and all(abs(i / 2 - 90 - 39.8) < 8 for i in near), near
        assert min(ranges) == pytest.approx(math.hypot(0.27, 0.22), abs=0.02)
        assert ranges[180] == pytest.approx(4.5, abs=0.01)
        assert ranges[0] == pytest.approx(2.5, abs=0.01)
    # PyBullet's rays start where each leaves the dart's outline, not its box
    render = dataclasses.replace(spec, sim=dataclasses.replace(spec.sim, fidelity="render"))
    with Simulation(render, seed=1) as sim:
        sim.step()
        rendered = sim.range_model.reading("dart", "laser")
        assert np.abs(np.asarray(rendered) - np.asarray(ranges)).max() < 0.01
