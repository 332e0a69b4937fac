"""The `ir` device kind end to end: its world-file table, its model over a real PyBullet world
in both fidelities, and ranger:1 of a real server read by the project's client over TCP."""

from __future__ import annotations

import math
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

from player_server.client import PlayerClient, PlayerNack, RangerProxy, SimulationProxy
from player_server.protocol import sensor_msgs as sm
from player_server.server.assembly import world_endpoints
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from player_server.sim.devices.ir import IrModel
from worlds import WorldError, WorldSpec, load_world, parse_world
from worlds.devices.ir import IrSpec
from worlds.to_toml import world_to_toml

pytestmark = pytest.mark.timeout(120)

# A robot at x = 0.55 facing a block whose near face is at x = 0.9; the body's front is at
# 0.55 - 0.04 + 0.445 / 2 = 0.7325, so the beam straight ahead runs 0.1675 m.
WORLD = """
[arena]
size = [4, 4]
[[arena.obstacles]]
name = "block"
pose = [1.0, 0.0, 0.0]
size = [0.2, 1.0]
[[robots]]
name = "r1"
pose = [0.55, 0.0, 0.0]
[robots.position2d]
[robots.power]
[robots.ir]
"""


def _expected() -> tuple[float, ...]:
    """The five beams at -72, -36, 0, 36, 72 deg: 0.3 (nothing) where the block is beyond."""
    cx, half_l, half_w, face = 0.51, 0.2225, 0.2, 0.9
    out = []
    for deg in (-72.0, -36.0, 0.0, 36.0, 72.0):
        a = math.radians(deg)
        d = min(half_l / max(abs(math.cos(a)), 1e-12), half_w / max(abs(math.sin(a)), 1e-12))
        run = (face - (cx + d * math.cos(a))) / math.cos(a)
        out.append(run if run < 0.3 else 0.3)
    return tuple(out)


@pytest.fixture
def world(tmp_path: Path) -> WorldSpec:
    path = tmp_path / "ir.toml"
    path.write_text(WORLD, encoding="utf-8")
    return load_world(path)


def test_the_table_reads_with_defaults_and_writes_back(world: WorldSpec) -> None:
    spec = world.robots[0].devices.get("ir")
    assert spec == IrSpec()
    assert world.robots[0].devices.names() == ("position2d", "power", "ir")
    assert world.robots[0].devices.power.sensor_w == 0.5  # the ir's draw
    again = parse_world(tomllib.loads(world_to_toml(world)), world.source)
    assert again.robots == world.robots


@pytest.mark.parametrize(("entry", "message"), [
    ("max_range = -1", "robots[0].ir.max_range: expected a number > 0, found -1"),
    ("count = 0", "robots[0].ir.count: expected an integer >= 1, found 0"),
    ("fov_deg = 400", "robots[0].ir.fov_deg: expected an angle <= 360 deg, found 400"),
    ("z = \"low\"", "robots[0].ir.z: expected a number, found 'low'"),
    ("range = 1", "robots[0].ir.range: expected one of the known keys (count, fov_deg, "
                  "fov_rad, max_range, z), found 'range'"),
])
def test_bad_values_name_the_key(tmp_path: Path, entry: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(WORLD + entry + "\n", encoding="utf-8")
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert str(err.value) == f"{path}: {message}"


@pytest.mark.parametrize("fidelity", ["fast", "render"])
def test_the_beams_meet_the_block(world: WorldSpec, fidelity: str) -> None:
    sim = Simulation(world, seed=1, fidelity=fidelity)
    try:
        sim.step(3)
        ranges = sim.model(IrModel).ranges("r1")
        assert ranges == pytest.approx(_expected(), abs=3e-3)
        sim.set_pose("r1", -1.0, 0.0, 0.0)
        sim.step(1)
        assert sim.model(IrModel).ranges("r1") == (0.3,) * 5
    finally:
        sim.close()


@pytest.fixture
def server(world: WorldSpec) -> Iterator[PlayerServer]:
    sim = Simulation(world, seed=1)
    srv = PlayerServer(sim, world_endpoints(world, sim, 0, allow_world_control=True),
                       interval_s=sim.interval_s, clock=time.monotonic, speedup=20.0)
    try:
        srv.start()
        yield srv
    finally:
        srv.stop()
        sim.close()


def test_ranger_1_over_tcp(server: PlayerServer) -> None:
    with PlayerClient("127.0.0.1", server.ports["r1"], timeout_s=30.0,
                      read_timeout_s=10.0) as client:
        assert (62, 1) in {(d.interf, d.index) for d in client.devlist()}
        assert client.driver_name(62, 1) == "sim_ir"
        ir = client.subscribe(RangerProxy, index=1)
        geom = ir.get_geometry()
        assert len(geom.element_poses) == 5
        ahead = geom.element_poses[2]
        assert (ahead.px, ahead.py, ahead.pz, ahead.pyaw) == pytest.approx((0.1825, 0, 0.1, 0))
        cfg = ir.get_config()
        assert (cfg.min_angle, cfg.max_angle, cfg.max_range) == pytest.approx(
            (math.radians(-72), math.radians(72), 0.3))
        with pytest.raises(PlayerNack):
            ir.set_config(sm.RangerConfig(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
        client.read()
        assert ir.ranges == pytest.approx(_expected(), abs=3e-3)

        sim = client.subscribe(SimulationProxy)
        sim.set_pose2d("r1", -1.0, 0.0, 0.0)
        for _ in range(50):  # the pose is set at the next tick
            client.read()
            if ir.ranges == (0.3,) * 5:
                break
        assert ir.ranges == (0.3,) * 5
