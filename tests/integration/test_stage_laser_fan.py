"""Laser configurations finer than, or off, the world's readings: the simulator casts them.

A SICK-like laser (361 readings over 180 degrees) faces a wall 2 m ahead; SET_CONFIG at
0.25, 0.5 and 1 degree over windows that are not on its readings is ACKed, and the served
scan has one reading per configured angle, each where a ray at that angle meets the wall.
Served over real TCP, read with the Python client.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from sibling import load_sibling

from player_server.client import LaserProxy, PlayerClient, PlayerNack, RangerProxy
from player_server.protocol import sensor_msgs as sm
from player_server.server.stage_source import load_stage_source
from player_server.sim import Simulation

INCLUDE = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "include"
WALL_X = 2.0  # the wall's near face
LASER_X = 0.2  # the laser's mount ahead of the robot's origin (sick.inc)

WORLD = f"""
include "{INCLUDE}/pioneer.inc"
include "{INCLUDE}/sick.inc"
interval_sim 100

pioneer2dx( name "robot1" pose [ 0 0 0 0 ] sicklaser() )
model( name "wall" pose [ {WALL_X + 0.1} 0 0 0 ] size [ 0.2 8 0.5 ] color "gray" )
"""

CFG = """
driver ( name "stage" model "robot1" provides [ "7201:position2d:0" "7201:ranger:1" ]
         worldfile "fan.world" )
driver ( name "rangertolaser" requires [ "7201:ranger:1" ] provides [ "7201:laser:0" ] )
"""


@pytest.fixture(scope="module")
def cfg(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("fan")
    (d / "fan.world").write_text(WORLD)
    (d / "fan.cfg").write_text(CFG)
    return d / "fan.cfg"


_stage = load_sibling(__file__, "stage_serving.py")
client = _stage.robot1


def _config(lo_deg: float, hi_deg: float, res: float) -> sm.LaserConfig:
    return sm.LaserConfig(math.radians(lo_deg), math.radians(hi_deg), res, 0.0, 0.0, 0, 0.0)


def _scan(cl: PlayerClient, laser: LaserProxy) -> sm.LaserData:
    for _ in range(2):
        cl.read()
    assert laser.scan is not None
    return laser.scan


def _check_on_the_wall(scan: sm.LaserData, lo_deg: float, res_deg: float, n: int) -> None:
    assert len(scan.ranges) == n
    assert scan.min_angle == pytest.approx(math.radians(lo_deg), abs=1e-6)
    assert scan.resolution == pytest.approx(math.radians(res_deg), abs=1e-6)
    assert scan.max_angle == pytest.approx(math.radians(lo_deg + (n - 1) * res_deg), abs=1e-6)
    checked = 0
    for i, r in enumerate(scan.ranges):
        a = math.radians(lo_deg + i * res_deg)
        if abs(a) > math.radians(60.0):  # the ray passes the wall's end (4 m either side)
            continue
        assert r == pytest.approx((WALL_X - LASER_X) / math.cos(a), abs=0.01), (i, r)
        checked += 1
    assert checked >= min(n, 30)


@pytest.mark.parametrize(("lo", "hi", "res", "n"), [
    (-44.87, 30.1, 25.0, 300),  # 0.25 degree, neither end on the world's readings
    (-90.0, 90.0, 50.0, 361),  # the world's own scan, asked for
    (-10.3, 20.7, 100.0, 32),
    (-60.25, 60.25, 50.0, 242),  # ends between two readings
])
def test_finer_and_off_grid_scans_are_cast_at_their_angles(
        cfg: Path, lo: float, hi: float, res: float, n: int) -> None:
    with client(cfg) as cl:
        laser = cl.subscribe(LaserProxy)
        ranger = cl.subscribe(RangerProxy, 1)
        default = _scan(cl, laser)
        assert len(default.ranges) == 361
        got = laser.set_config(_config(lo, hi, res))
        assert got.resolution == res
        now = laser.get_config()
        assert now.min_angle == pytest.approx(math.radians(lo), abs=1e-6)
        assert now.max_angle == pytest.approx(math.radians(lo + (n - 1) * res / 100),
                                              abs=1e-6)
        assert now.resolution == res
        scan = _scan(cl, laser)
        _check_on_the_wall(scan, lo, res / 100, n)
        if n == 361:
            assert scan.ranges == default.ranges
        rc = ranger.get_config()  # the ranger view of the laser follows (in radians)
        assert (rc.min_angle, rc.angular_res) == pytest.approx(
            (math.radians(lo), math.radians(res / 100)), abs=1e-6)
        assert len(ranger.ranges) == n
        # back to the world's scan: the same readings as before
        laser.set_config(_config(-90.0, 90.0, 50.0))
        assert _scan(cl, laser).ranges == default.ranges


@pytest.mark.parametrize(("lo", "hi", "res"), [
    (-95.0, 30.0, 25.0),  # beyond the field of view
    (-30.0, 90.5, 100.0),
    (10.0, -10.0, 50.0),  # min > max
    (-10.3, 20.7, 30.0),  # not a SICK resolution and not a multiple of the world's
    (-10.3, 20.7, 75.0),
    (math.nan, 20.0, 50.0),
    (-10.0, math.inf, 50.0),
    (-60.1, 60.0, 25.0),  # 0.25 degree over more than 100 degrees (a SICK cannot)
])
def test_impossible_configurations_are_nacked_and_change_nothing(
        cfg: Path, lo: float, hi: float, res: float) -> None:
    with client(cfg) as cl:
        laser = cl.subscribe(LaserProxy)
        laser.set_config(_config(-10.3, 20.7, 100.0))
        before = laser.get_config()
        with pytest.raises(PlayerNack):
            laser.set_config(_config(lo, hi, res))
        assert laser.get_config() == before
        _check_on_the_wall(_scan(cl, laser), -10.3, 1.0, 32)


def test_a_fan_is_kept_across_a_reset_and_dropped_when_asked(cfg: Path) -> None:
    world, _ = load_stage_source(str(cfg), 0)
    with Simulation(world.spec, seed=1) as sim:
        sim.step()
        default = sim.laser("robot1").copy()
        sim.set_scan_fan("robot1", "laser", (math.radians(-10.3), math.radians(1.0), 32))
        assert len(sim.laser("robot1")) == 32  # this tick's reading is made again
        sim.reset()  # the drivers still hold their configuration: so does the simulator
        sim.step()
        assert len(sim.laser("robot1")) == 32
        sim.set_scan_fan("robot1", "laser", None)
        assert sim.laser("robot1").tobytes() == default.tobytes()
        with pytest.raises(ValueError):
            sim.set_scan_fan("robot1", "laser", (0.0, 0.0, 3))
        with pytest.raises(ValueError):
            sim.set_scan_fan("robot1", "sonar", (0.0, 0.01, 3))
