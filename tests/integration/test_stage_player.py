"""Stage worlds and Player .cfg files served over real TCP, read with the Python client.

The world is written here with a floorplan bitmap drawn here; the laser's ranges are checked
against rays cast on that bitmap; the .cfg's ports and devices are served as it says.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sibling import load_sibling

from player_server.client import (
    LaserProxy,
    PlayerClient,
    PlayerNack,
    Position2dProxy,
    PowerProxy,
    RangerProxy,
)
from player_server.client.device_proxies import SimulationProxy
from player_server.protocol import sensor_msgs as sm
from player_server.sim import Simulation

INCLUDE = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "include"
PX = 0.1  # metres per pixel of the test floorplan
SIZE = 100  # pixels a side: a 10 x 10 m map


def _bitmap(path: Path) -> np.ndarray:
    """Walls: a bar across at y = +2 m (x -5..0 m), a block at x 2..3 m, y -1..1 m."""
    from PIL import Image

    solid = np.zeros((SIZE, SIZE), dtype=bool)
    solid[28:31, 0:50] = True  # rows 28..30: y from +2.2 down to +1.9
    solid[40:60, 70:80] = True
    img = np.where(solid, 0, 255).astype(np.uint8)
    Image.fromarray(img, mode="L").save(path)
    border = solid.copy()  # `boundary 1` walls in the edge pixels
    border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
    return border


WORLD = f"""
# a test world: one scout in a walled 10 x 10 m floorplan, a friend, pucks, a dock
include "{INCLUDE}/pioneer.inc"
include "{INCLUDE}/sick.inc"
include "{INCLUDE}/map.inc"

interval_sim 100
window ( size [ 400 400 ] )

floorplan ( name "map" bitmap "walls.png" size [ 10 10 0.6 ] )

define scout pioneer2dx
(
  sicklaser( pose [ 0.2 0 0.03 0 ] )
  blobfinder( colors_count 1 colors [ "orange" ] image [ 80 60 ] range 6 fov 60 )
  gripper( pose [ 0.23 0 -0.2 0 ] )
)

scout( name "robot1" pose [ -2 -2 0 0 ] )
scout( name "robot2" pose [ -3.5 -3.5 0 180 ] color "blue" )
puck( name "puck1" pose [ -3 3.5 0 0 ] )
charger( name "dock" pose [ 4.5 -4 0 0 ] )
zone( name "home" pose [ -4 -4 0 0 ] )
"""

CFG = """
driver ( name "stage" plugin "stageplugin" provides [ "7001:simulation:0" ]
         worldfile "test.world" )
driver ( name "stage" model "robot1"
         provides [ "7001:position2d:0" "7001:ranger:0" "7001:ranger:1" "7001:gripper:0"
                    "7001:blobfinder:0" "7001:power:0" ] )
driver ( name "stage" model "robot2" provides [ "7002:position2d:0" "7002:ranger:1" ] )
driver ( name "rangertolaser" requires [ "7001:ranger:1" ] provides [ "7001:laser:0" ] )
driver ( name "amcl" requires [ "7001:laser:0" ] provides [ "7001:localize:0" ] )
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    d = tmp_path_factory.mktemp("stage")
    solid = _bitmap(d / "walls.png")
    (d / "test.world").write_text(WORLD)
    (d / "test.cfg").write_text(CFG)
    return d, solid


_stage = load_sibling(__file__, "stage_serving.py")
serve = _stage.serve


def _client(port: int) -> PlayerClient:
    return PlayerClient("127.0.0.1", port, timeout_s=10.0, read_timeout_s=10.0)


def _cast(solid: np.ndarray, x: float, y: float, a: float, max_range: float) -> float:
    """March along a ray over the bitmap (centre of the map at the origin, row 0 at +y)."""
    step = 0.002
    c, s = math.cos(a), math.sin(a)
    for i in range(1, int(max_range / step) + 1):
        px, py = x + c * i * step, y + s * i * step
        col = int((px + SIZE * PX / 2) / PX)
        row = int((SIZE * PX / 2 - py) / PX)
        if not (0 <= row < SIZE and 0 <= col < SIZE) or solid[row, col]:
            return i * step
    return max_range


def test_cfg_is_served_exactly_as_written(files: tuple[Path, np.ndarray]) -> None:
    d, _ = files
    with serve(d / "test.cfg") as (srv, ports):
        assert ports == [7001, 7002]
        by_name = {ep.name: ep for ep in srv.endpoints}
        assert set(by_name) == {"robot1", "robot2"}
        with _client(by_name["robot1"].port) as cl:
            names = sorted(f"{i}:{x}" for i, x in ((dev.interf, dev.index)
                                                    for dev in cl.devlist()))
        assert len(names) == 8  # simulation, position2d, 2 rangers, gripper, blob, power, laser
        with _client(by_name["robot2"].port) as cl:
            got = {(a.interf, a.index) for a in cl.devlist()}
        assert got == {(4, 0), (62, 1)}  # position2d:0 and ranger:1 only, as written


def test_laser_sees_the_bitmap_walls_where_rays_on_the_bitmap_do(
        files: tuple[Path, np.ndarray]) -> None:
    d, solid = files
    with serve(d / "test.cfg") as (srv, _), _client(srv.ports["robot1"]) as cl:
        sim = cl.subscribe(SimulationProxy)
        laser = cl.subscribe(LaserProxy)
        for _ in range(5):
            cl.read()
        x, y, yaw = sim.get_pose2d("robot1")
        cfg = laser.get_config()
        ranges = laser.ranges
        assert len(ranges) == 361
        lx, ly = x + 0.2 * math.cos(yaw), y + 0.2 * math.sin(yaw)
        checked = 0
        for i in range(0, 361, 4):
            a = yaw + cfg.min_angle + i * cfg.resolution
            want = _cast(solid, lx, ly, a, cfg.max_range)
            if want >= cfg.max_range - 0.05:
                continue
            # robot2, the puck and the dock are not in the bitmap: skip rays that hit them
            if abs(ranges[i] - want) > 0.04 and ranges[i] < want:
                continue
            assert ranges[i] == pytest.approx(want, abs=0.04), (i, math.degrees(a))
            checked += 1
        assert checked > 40


def test_laser_set_config_round_trip_as_libplayerc_sends_it(
        files: tuple[Path, np.ndarray]) -> None:
    d, _ = files
    with serve(d / "test.cfg") as (srv, _), _client(srv.ports["robot1"]) as cl:
        laser = cl.subscribe(LaserProxy)
        ranger = cl.subscribe(RangerProxy, 1)
        # libplayerc's test: +-90 deg, resolution 100 (0.01 deg), range_res 1 (mm), intensity
        laser.set_config(sm.LaserConfig(-math.pi / 2, math.pi / 2, 100.0, 0.0, 1.0, 1, 0.0))
        got = laser.get_config()
        assert got.min_angle == pytest.approx(-math.pi / 2, abs=1e-4)
        assert got.max_angle == pytest.approx(math.pi / 2, abs=1e-4)
        assert (got.resolution, got.range_res, got.intensity) == (100.0, 1.0, 1)
        for _ in range(3):
            cl.read()
        assert len(laser.ranges) == 181 and len(laser.intensity) == 181
        assert set(laser.intensity) <= {0, 1} and 1 in laser.intensity
        # the ranger view of the same laser follows the same configuration (in radians)
        rc = ranger.get_config()
        assert rc.angular_res == pytest.approx(math.radians(1.0), abs=1e-6)
        # a 0.25 degree resolution over 180 degrees is impossible for a SICK: NACKed
        with pytest.raises(PlayerNack):
            laser.set_config(sm.LaserConfig(-math.pi / 2, math.pi / 2, 25.0, 0.0, 1.0, 0, 0.0))
        # the ranger interface's own SET_CONFIG: narrower, coarser, shorter
        want = sm.RangerConfig(-math.pi / 4, math.pi / 4, math.radians(2.0), 0.0, 5.0, 0.01,
                               0.0)
        now = ranger.set_config(want)
        assert (now.angular_res, now.max_range) == pytest.approx((math.radians(2.0), 5.0))
        for _ in range(3):
            cl.read()
        assert len(ranger.ranges) == 46 and max(ranger.ranges) <= 5.0
        with pytest.raises(PlayerNack):
            ranger.set_config(sm.RangerConfig(-math.pi, math.pi, math.radians(1.0), 0.0, 5.0,
                                              0.01, 0.0))
        assert laser.get_config().max_range == pytest.approx(5.0)


def test_sonar_ranger_and_simulation_interface_by_name(
        files: tuple[Path, np.ndarray]) -> None:
    d, _ = files
    with serve(d / "test.cfg", world_control=True) as (srv, _), \
            _client(srv.ports["robot1"]) as cl:
        sonar = cl.subscribe(RangerProxy, 0)
        cl.subscribe(Position2dProxy)
        sim = cl.subscribe(SimulationProxy)
        cl.read()
        assert len(sonar.get_geometry().element_poses) == 16
        assert sim.get_pose2d("home") == pytest.approx((-4.0, -4.0, 0.0))
        assert sim.get_pose2d("map") == pytest.approx((0.0, 0.0, 0.0))
        assert sim.get_pose2d("dock") == pytest.approx((4.5, -4.0, 0.0))
        sim.set_pose2d("puck1", -1.0, 3.5, 0.0)
        assert sim.get_pose2d("puck1")[:2] == pytest.approx((-1.0, 3.5), abs=0.02)
        sim.set_pose2d("robot1", 1.0, -3.0, math.pi / 2)
        x, y, yaw = sim.get_pose2d("robot1")
        assert (x, y, yaw) == pytest.approx((1.0, -3.0, math.pi / 2), abs=0.02)
        rgba = np.frombuffer(sim.get_property("robot1", "_mp_color"), dtype="<f4")
        assert tuple(rgba) == pytest.approx((1.0, 0.0, 0.0, 1.0))
        with pytest.raises(PlayerNack):
            sim.set_property("robot1", "_mp_color", (0xFF00).to_bytes(4, "little"))
        with pytest.raises(PlayerNack):
            sim.get_pose2d("nobody")
        with pytest.raises(PlayerNack):
            sim.set_pose2d("home", 0.0, 0.0, 0.0)  # a zone does not move here
        # the dock gives watts: a robot touching it charges through its power device
        power = cl.subscribe(PowerProxy)
        for _ in range(3):
            cl.read()
        assert power.state_values is not None and power.state_values[5] == 0
        sim.set_pose2d("robot1", 4.15, -4.0, 0.0)  # nose against the dock's face
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and not (power.state_values or (0,) * 6)[5]:
            cl.read()
        assert power.state_values is not None and power.state_values[5] == 1


def test_world_control_is_refused_without_the_option(files: tuple[Path, np.ndarray]) -> None:
    d, _ = files
    with serve(d / "test.cfg") as (srv, _), _client(srv.ports["robot1"]) as cl:
        sim = cl.subscribe(SimulationProxy)
        before = sim.get_pose2d("robot1")
        with pytest.raises(PlayerNack):
            sim.set_pose2d("robot1", 0.0, 0.0, 0.0)
        assert sim.get_pose2d("robot1") == pytest.approx(before, abs=0.01)


def _player_server(*args: str, timeout_s: float = 60.0) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONUNBUFFERED="0")
    env.pop("PYTHONUNBUFFERED")
    return subprocess.Popen([sys.executable, "-m", "player_server.server", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def test_player_server_prints_its_table_at_once_through_a_pipe_and_as_json(
        files: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    d, _ = files
    out = tmp_path / "ports.json"
    proc = _player_server(str(d / "test.cfg"), "-p", "0", "--ports-json", str(out))
    try:
        lines: list[str] = []
        assert proc.stdout is not None
        deadline = time.monotonic() + 60.0
        while len(lines) < 4 and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line)
        assert lines[1].split()[:2] == ["robot", "port"], lines
        table = json.loads(out.read_text())["endpoints"]
        assert [e["configured_port"] for e in table] == [7001, 7002]
        assert [e["name"] for e in table] == ["robot1", "robot2"]
        port = table[1]["port"]
        assert f"robot2  {port}" in "".join(lines) or str(port) in lines[3]
        with _client(port) as cl:
            assert len(cl.devlist()) == 2
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=30)
    assert "driver 'amcl' is not provided here" in err
    assert err.count("'amcl'") == 1


@pytest.mark.parametrize(("text", "expected"), [
    ('driver ( name "stage" provides [ "position2d:0" ] )\n'
     'driver ( name "stage" provides [ "simulation:0" ] worldfile "test.world" )',
     'test.cfg:1: expected model "NAME" in the stage driver providing 6665:position2d:0'),
    ('driver ( name "stage" provides [ "simulation:0" ] worldfile "nowhere.world" )',
     "nowhere.world: expected a readable text file"),
    ('driver ( name "stage" provides [ "simulation:0" ] worldfile "test.world"\n',
     "test.cfg:2: expected a key, a child entity or ) in driver, found end of file"),
])
def test_bad_cfg_is_one_line_and_exit_2(files: tuple[Path, np.ndarray], tmp_path: Path,
                                        text: str, expected: str) -> None:
    d, _ = files
    cfg = d / "test.cfg"
    bad = d / f"bad{abs(hash(text))}.cfg"
    bad.write_text(text)
    proc = _player_server(str(bad), "-p", "0")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    lines = [ln for ln in err.splitlines() if ln.startswith("player-server:")]
    assert len(lines) == 1 and "Traceback" not in err
    assert expected.replace("test.cfg", bad.name) in lines[0] or expected in lines[0], lines
    assert cfg.exists()


def test_murdoch_world_convert_prints_a_toml_world(files: tuple[Path, np.ndarray]) -> None:
    import tomllib

    from worlds import load_world
    from worlds.loader import parse_world

    d, _ = files
    proc = subprocess.run([sys.executable, "-c", "from experiments.cli import main; main()",
                           "world", "convert", str(d / "test.world")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    again = parse_world(tomllib.loads(proc.stdout), d / "test.world")
    assert again == load_world(d / "test.world")


def test_a_world_is_served_one_port_per_position_model(files: tuple[Path, np.ndarray]) -> None:
    d, _ = files
    with serve(d / "test.world") as (srv, ports):
        assert ports == [6665, 6666]
        with _client(srv.ports["robot2"]) as cl:
            got = {(a.interf, a.index) for a in cl.devlist()}
        assert {(4, 0), (62, 0), (62, 1), (6, 0), (5, 0), (31, 0)} <= got


def test_many_floorplan_walls_are_solid_to_a_driving_robot(tmp_path: Path) -> None:
    """A bitmap of many walls (built as compound bodies) stops a robot driving into it."""
    from PIL import Image

    from worlds.stage import load_stage_world

    img = np.full((100, 100), 255, dtype=np.uint8)
    for k in range(100):  # a diagonal wall, one box per row; at y = 0 (row 50) x is 2 m
        img[k, 20 + k: 24 + k] = 0
    Image.fromarray(img, mode="L").save(tmp_path / "stairs.png")
    world_file = tmp_path / "stairs.world"
    world_file.write_text(f'include "{INCLUDE}/pioneer.inc"\n'
                          'model( name "m" bitmap "stairs.png" size [10 10 0.5] '
                          'obstacle_return 1 )\n'
                          'pioneer2dx( name "r" pose [0 0 0 0] )\n')
    spec = load_stage_world(world_file).spec
    assert len(spec.arena.obstacles) > 64
    sim = Simulation(spec, seed=1)
    try:
        sim.set_velocity("r", 0.5, 0.0)
        sim.step(80)  # 8 s at 0.5 m/s would carry it 4 m, through the wall at x = 2 m
        x, _, _ = sim.get_pose("r")
        assert 1.2 < x < 2.0
    finally:
        sim.close()


def test_the_long_term_experiment_runs_on_the_shipped_stage_world(tmp_path: Path) -> None:
    world = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "pioneers.world"
    proc = subprocess.run(
        [sys.executable, "-c", "from experiments.cli import main; main()", "run", "longterm",
         "--world", str(world), "--until", "20s", "--no-plots", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (summary,) = tmp_path.glob("longterm-*/summary.json")
    got = json.loads(summary.read_text())
    assert got["end_reason"] == "completed"
    assert set(got["distance_m"]["by_robot"]) == {"robot1", "robot2"}
