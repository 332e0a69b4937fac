"""The `imu` device kind end to end: its world-file table, its model over a real PyBullet world
in both fidelities, and imu:0 of a real server read by the project's client over TCP, with
SET_DATATYPE choosing the DATA and a driving robot's turn rate and accelerations in it."""

from __future__ import annotations

import math
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

from player_server.client import ImuProxy, PlayerClient, PlayerNack, Position2dProxy
from player_server.client.print_tool import render
from player_server.protocol import constants as c
from player_server.protocol import imu_msgs as im
from player_server.server.assembly import world_endpoints
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from player_server.sim.devices.imu import GRAVITY_MPS2, ImuModel
from worlds import WorldError, WorldSpec, load_world, parse_world
from worlds.devices.imu import ImuSpec
from worlds.spec import Mount
from worlds.to_toml import world_to_toml

pytestmark = pytest.mark.timeout(120)

# The drive reaches 0.3 m/s at 0.5 m/s^2 (0.6 s) and 0.5 rad/s at 200 deg/s^2 (0.15 s); the
# unit above the axle then turns at 0.5 rad/s and feels v * w = 0.15 m/s^2 to its left.
WORLD = """
[arena]
size = [6, 6]
[[robots]]
name = "r1"
pose = [0.0, 0.0, 30.0]
[robots.position2d]
[robots.power]
[robots.imu]
"""
V, W = 0.3, 0.5
YAW0 = math.radians(30.0)


@pytest.fixture
def world(tmp_path: Path) -> WorldSpec:
    path = tmp_path / "imu.toml"
    path.write_text(WORLD, encoding="utf-8")
    return load_world(path)


def _with(table: str) -> WorldSpec:
    return parse_world(tomllib.loads(WORLD + table), Path("imu.toml"))


def test_the_table_reads_with_defaults_and_writes_back(world: WorldSpec) -> None:
    assert world.robots[0].devices.get("imu") == ImuSpec()
    assert world.robots[0].devices.names() == ("position2d", "power", "imu")
    power = world.robots[0].devices.power
    assert power is not None and power.sensor_w == 0.1  # the imu's draw
    again = parse_world(tomllib.loads(world_to_toml(world)), world.source)
    assert again.robots == world.robots
    given = _with("pose = [0.1, -0.05, 0.3, 90]\ndatatype = 2\nyaw_noise_deg = 1\n"
                  "yaw_drift = 0.001\ngyro_noise = 0.01\naccel_noise = 0.05\n")
    spec = given.robots[0].devices.get("imu")
    assert spec == ImuSpec(Mount(0.1, -0.05, 0.3, math.pi / 2), 2, math.radians(1), 0.001,
                           0.01, 0.05)
    assert parse_world(tomllib.loads(world_to_toml(given)), given.source).robots == given.robots


@pytest.mark.parametrize(("entry", "message"), [
    ("datatype = 6", "robots[0].imu.datatype: expected an integer <= 5, found 6"),
    ("datatype = 0", "robots[0].imu.datatype: expected an integer >= 1, found 0"),
    ("gyro_noise = -1", "robots[0].imu.gyro_noise: expected a number >= 0, found -1"),
    ("yaw_noise_deg = -2", "robots[0].imu.yaw_noise_deg: expected an angle >= 0 deg, found -2"),
    ("pose = [1, 2]", "robots[0].imu.pose: expected [x, y, z, yaw_deg] numbers, found [1, 2]"),
    ("noise = 1", "robots[0].imu.noise: expected one of the known keys (accel_noise, datatype, "
                  "gyro_noise, pose, yaw_drift, yaw_noise_deg, yaw_noise_rad), found 'noise'"),
])
def test_bad_values_name_the_key(tmp_path: Path, entry: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(WORLD + entry + "\n", encoding="utf-8")
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert str(err.value) == f"{path}: {message}"


@pytest.mark.parametrize("fidelity", ["fast", "render"])
def test_a_turning_robot_is_felt(world: WorldSpec, fidelity: str) -> None:
    sim = Simulation(world, seed=1, fidelity=fidelity)
    try:
        imu = sim.model(ImuModel)
        still = imu.reading("r1")
        assert still.yaw == pytest.approx(YAW0)
        assert still.gyro == (0.0, 0.0, 0.0) and still.accel == (0.0, 0.0, GRAVITY_MPS2)
        sim.set_velocity("r1", V, W)
        sim.step(2)  # speeding up: forward acceleration, turn rate reached
        r = imu.reading("r1")
        assert r.accel[0] == pytest.approx(0.5, abs=0.01)
        assert r.gyro[2] == pytest.approx(W)
        sim.step(10)  # steady: only the centripetal acceleration
        r = imu.reading("r1")
        assert r.gyro[2] == pytest.approx(W)
        assert r.accel[:2] == pytest.approx((0.0, V * W), abs=0.005)
        assert r.vel[0] == pytest.approx(V, abs=0.005)
        assert r.yaw == pytest.approx(sim.get_pose("r1")[2])
        imu.reset_orientation("r1")
        assert imu.reading("r1").yaw == 0.0
        sim.step(10)
        assert imu.reading("r1").yaw == pytest.approx(W * 10 * sim.interval_s, abs=1e-6)
        sim.set_pose("r1", 1.0, 1.0, 0.0)  # a teleport leaves the body at rest
        sim.set_velocity("r1", 0.0, 0.0)
        sim.step(2)
        r = imu.reading("r1")
        assert r.vel == (0.0, 0.0, 0.0) and r.gyro[2] == 0.0 and r.accel[:2] == (0.0, 0.0)
    finally:
        sim.close()


def test_a_mount_off_the_axle_feels_the_turn_and_sits_turned() -> None:
    """0.2 m ahead of the axle and turned left by 90 deg (its x is the robot's left, its y
    the robot's back): on the spot the unit moves left at w * 0.2, along its x, and the
    centripetal acceleration, w^2 * 0.2 back towards the axle, lies along its y."""
    sim = Simulation(_with("pose = [0.2, 0.0, 0.2, 90]\n"), seed=1)
    try:
        sim.set_velocity("r1", 0.0, W)
        sim.step(12)
        r = sim.model(ImuModel).reading("r1")
        assert r.accel[:2] == pytest.approx((0.0, W * W * 0.2), abs=0.005)
        assert r.vel[:2] == pytest.approx((W * 0.2, 0.0), abs=0.005)
        turned = r.yaw - (sim.get_pose("r1")[2] + math.pi / 2)
        assert math.remainder(turned, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    finally:
        sim.close()


def test_noise_is_seeded_by_the_world_and_not_by_who_read_first() -> None:
    world = _with("yaw_noise_deg = 2\ngyro_noise = 0.05\naccel_noise = 0.1\n")
    sims = [Simulation(world, seed=s) for s in (7, 7, 8)]
    try:
        for sim in sims:
            sim.set_velocity("r1", V, W)
        for _ in range(20):
            for sim in sims[:1]:
                sim.model(ImuModel).reading("r1")  # one is read every tick, the others not
                sim.step(1)
            for sim in sims[1:]:
                sim.step(1)
        a, b, other = (sim.model(ImuModel).reading("r1") for sim in sims)
        assert a == b and a != other
        assert a.gyro[2] != W and abs(a.gyro[2] - W) < 0.5
        assert a.accel[2] != GRAVITY_MPS2
    finally:
        for sim in sims:
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


def test_imu_0_over_tcp(server: PlayerServer) -> None:
    with PlayerClient("127.0.0.1", server.ports["r1"], timeout_s=30.0,
                      read_timeout_s=10.0) as client:
        assert (60, 0) in {(d.interf, d.index) for d in client.devlist()}
        assert client.driver_name(60, 0) == "sim_imu"
        imu = client.subscribe(ImuProxy)
        client.read()
        assert imu.datatype == c.PLAYER_IMU_DATA_EULER  # the world file's datatype
        assert isinstance(imu.state, im.ImuDataEuler)
        assert imu.yaw == pytest.approx(YAW0) and imu.accel == pytest.approx((0, 0, 9.81))
        assert imu.capable(int(c.MsgType.REQ), c.PLAYER_IMU_REQ_SET_DATATYPE)
        assert "orientation: {proll=0.000, ppitch=0.000, pyaw=0.524}" in render(imu)

        for datatype, cls in [(1, im.ImuDataState), (2, im.ImuDataCalib), (3, im.ImuDataQuat),
                              (5, im.ImuDataFullstate), (4, im.ImuDataEuler)]:
            imu.set_datatype(datatype)
            client.read()
            assert (imu.datatype, type(imu.state)) == (datatype, cls)
            assert imu.yaw == (None if datatype == 2 else pytest.approx(YAW0))
        with pytest.raises(PlayerNack):
            imu.set_datatype(6)
        with pytest.raises(PlayerNack):
            imu.request(3)  # no such imu request
        client.read()
        assert imu.datatype == c.PLAYER_IMU_DATA_EULER

        pos = client.subscribe(Position2dProxy)
        pos.set_velocity(V, W)
        gyro, accel = _read_until_steady(client, imu)
        assert gyro[2] == pytest.approx(W, abs=1e-6)
        assert accel == pytest.approx((0.0, V * W, 9.81), abs=0.005)

        imu.set_datatype(c.PLAYER_IMU_DATA_FULLSTATE)
        client.read()
        assert isinstance(imu.state, im.ImuDataFullstate)
        assert imu.state.vel.px == pytest.approx(V, abs=0.005)
        assert imu.state.vel.pyaw == pytest.approx(W, abs=1e-6)

        pos.set_velocity(0.0, 0.0)
        for _ in range(200):  # until it stands still
            client.read()
            if imu.gyro is not None and abs(imu.gyro[2]) < 1e-9:
                break
        assert imu.gyro == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
        imu.reset_orientation()
        client.read()
        assert imu.yaw == pytest.approx(0.0, abs=1e-9)


def _read_until_steady(client: PlayerClient, imu: ImuProxy
                       ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Rounds until the drive has reached its speeds (the turn rate, then the acceleration
    settle), at most 200."""
    steady = 0
    for _ in range(200):
        client.read()
        gyro, accel = imu.gyro, imu.accel
        assert gyro is not None and accel is not None
        steady = steady + 1 if abs(gyro[2] - W) < 1e-6 and abs(accel[0]) < 0.005 else 0
        if steady >= 3:
            return gyro, accel
    raise AssertionError(f"no steady turn: gyro {imu.gyro}, accel {imu.accel}")
