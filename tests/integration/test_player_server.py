"""The real server over a real PyBullet world, driven by our client over loopback TCP."""

from __future__ import annotations

import math
import socket
import struct
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from player_server.client import (
    BlobfinderProxy,
    BumperProxy,
    CameraProxy,
    FiducialProxy,
    GripperProxy,
    LaserProxy,
    PlayerClient,
    PlayerConnectionError,
    PlayerNack,
    Position2dProxy,
    PowerProxy,
    PtzProxy,
    RangerProxy,
    SimulationProxy,
    SonarProxy,
)
from player_server.protocol import constants as c
from player_server.protocol import encode_message
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(60)


@contextmanager
def serve(world: str = "simple", *, speedup: float = 0.0, paused: bool = False,
          config: CoreConfig | None = None, seed: int | None = None) -> Iterator[PlayerServer]:
    spec = load_world(world_path(world))
    sim = Simulation(spec, seed=seed)
    sim.set_paused(paused)
    # these tests move bodies and pause through simulation:0
    server = PlayerServer(sim, world_endpoints(spec, sim, 0, allow_world_control=True),
                          interval_s=sim.interval_s, clock=time.monotonic, speedup=speedup,
                          config=config)
    try:
        server.start()
        yield server
    finally:
        server.stop()
        sim.close()


@pytest.fixture(scope="module")
def server() -> Iterator[PlayerServer]:
    # Paced (200 ticks a second), not flat out: a serving thread that never waits would
    # hold the interpreter lock against the clients of this same process.
    with serve("simple", speedup=20.0) as srv:
        yield srv


@pytest.fixture
def client(server: PlayerServer) -> Iterator[PlayerClient]:
    with PlayerClient("127.0.0.1", server.ports["robot1"], timeout_s=5.0,
                      read_timeout_s=10.0) as cl:
        yield cl


def test_ports_and_table(server: PlayerServer) -> None:
    assert set(server.ports) == {"robot1", "overhead"}
    assert all(p > 0 for p in server.ports.values())
    table = server.table()
    assert "robot1" in table and "laser:0" in table and str(server.ports["overhead"]) in table


def test_banner_devlist_and_driver_names(client: PlayerClient, server: PlayerServer) -> None:
    assert client.banner == "Player v.3.1.1-dev"
    devs = {(d.interf, d.index) for d in client.devlist()}
    assert {(4, 0), (5, 0), (6, 0), (62, 0), (40, 0), (7, 0), (14, 0), (3, 0), (8, 0), (2, 0),
            (10, 0), (31, 0)} == devs
    assert client.driver_name(6, 0) == "sim_laser"
    with pytest.raises(PlayerNack):
        client.driver_name(13, 0)


def test_every_interface_delivers_data(client: PlayerClient) -> None:
    proxies = [client.subscribe(cls) for cls in (
        Position2dProxy, SonarProxy, LaserProxy, RangerProxy, BlobfinderProxy, BumperProxy,
        GripperProxy, PowerProxy, PtzProxy, FiducialProxy, CameraProxy)]
    t0 = None
    for _ in range(3):
        updated = client.read()
        # compare names: a proxy's repr holds its data (a whole camera image)
        assert sorted(type(p).__name__ for p in updated) == sorted(
            type(p).__name__ for p in proxies)
        assert t0 is None or client.data_time_s > t0  # type: ignore[operator]
        t0 = client.data_time_s
    pos, sonar, laser, ranger, blobs, bumper, gripper, power, ptz, fid, cam = proxies
    assert pos.data_time_s == client.data_time_s and pos.state is not None
    assert len(sonar.ranges) == 16 and all(0 <= r <= 5.0 + 1e-6 for r in sonar.ranges)
    assert len(laser.ranges) == 181 and all(0 <= r <= 8.0 + 1e-6 for r in laser.ranges)
    assert laser.min_angle == pytest.approx(-math.pi / 2, abs=1e-6)
    assert laser.resolution == pytest.approx(math.pi / 180, abs=1e-6)
    assert len(ranger.ranges) == 181
    assert blobs.width == 160 and blobs.height == 120
    assert any(b.color == 0xFF0000 for b in blobs.blobs)  # the red can straight ahead
    assert len(bumper.bumpers) > 0 and not bumper.pressed
    assert gripper.state in (c.PLAYER_GRIPPER_STATE_OPEN, c.PLAYER_GRIPPER_STATE_CLOSED)
    assert 0 < power.percent <= 100 and power.volts > 10 and power.watts < 0
    assert ptz.zoom > 0
    assert isinstance(fid.fiducials, tuple)
    assert (cam.width, cam.height) == (160, 120) and len(cam.image) == 160 * 120 * 3
    assert not cam.compressed
    laser.client.unsubscribe(cam)


def test_laser_and_sonar_match_the_world(client: PlayerClient) -> None:
    sim = client.subscribe(SimulationProxy)
    laser = client.subscribe(LaserProxy)
    sonar = client.subscribe(SonarProxy)
    pos = client.subscribe(Position2dProxy)
    pos.stop()
    # face the east wall (inner face at x = 4.0) from x = 3.0 in free floor
    sim.set_pose2d("robot1", 3.0, -2.0, 0.0)
    for _ in range(3):
        client.read()
    x, y, _ = sim.get_pose2d("robot1")
    assert (x, y) == pytest.approx((3.0, -2.0), abs=0.02)
    mount_x = 0.16
    assert laser.ranges[90] == pytest.approx(4.0 - x - mount_x, abs=0.05)
    assert min(sonar.ranges[3], sonar.ranges[4]) == pytest.approx(4.0 - x - 0.166, abs=0.08)
    geom = laser.get_geometry()
    assert (geom.pose.px, geom.pose.pz) == pytest.approx((0.16, 0.25))


def test_command_motion_changes_the_pose() -> None:
    # A lockstep server advances only as this client reads. A free-running one at full speed
    # runs the lone robot's battery flat within seconds of wall time, and a flat robot stops.
    with serve("simple", config=CoreConfig(lockstep=True)) as srv, PlayerClient(
        "127.0.0.1", srv.ports["robot1"], timeout_s=5.0, read_timeout_s=10.0
    ) as client:
        _command_motion_changes_the_pose(client)


def _command_motion_changes_the_pose(client: PlayerClient) -> None:
    sim = client.subscribe(SimulationProxy)
    pos = client.subscribe(Position2dProxy)
    sim.set_pose2d("robot1", -1.0, -2.0, 0.0)
    pos.set_odometry(0.0, 0.0, 0.0)
    client.read()
    t0 = client.data_time_s
    for _ in range(15):
        pos.set_velocity(0.3, 0.0)
        client.read()
    assert client.data_time_s > t0  # type: ignore[operator]
    assert pos.x > 0.1 and abs(pos.y) < 0.05 and pos.vx > 0.1
    x, _, _ = sim.get_pose2d("robot1")
    assert x > -0.9
    pos.stop()
    pos.goto(pos.x + 0.3, pos.y, 0.0)
    start = pos.x
    for _ in range(40):
        client.read()
    assert pos.x == pytest.approx(start + 0.3, abs=0.08)


def test_geometry_and_config_requests(client: PlayerClient) -> None:
    pos = client.subscribe(Position2dProxy)
    g = pos.get_geometry()
    assert (g.size.sw, g.size.sl) == pytest.approx((0.40, 0.445))
    sonar = client.subscribe(SonarProxy)
    poses = sonar.get_geometry()
    assert len(poses) == 16 and poses[0].pyaw == pytest.approx(math.radians(90))
    ranger = client.subscribe(RangerProxy)
    cfg = ranger.get_config()
    assert cfg.max_range == pytest.approx(8.0) and len(ranger.get_geometry().element_poses) == 1
    assert ranger.set_config(cfg) == cfg
    laser = client.subscribe(LaserProxy)
    lc = laser.get_config()
    assert lc.max_range == pytest.approx(8.0)
    bumper = client.subscribe(BumperProxy)
    assert len(bumper.get_geometry().bumper_def) > 0
    gripper = client.subscribe(GripperProxy)
    assert gripper.get_geometry().capacity >= 1
    fid = client.subscribe(FiducialProxy)
    assert fid.get_fov().max_range > 0
    assert pos.get_dbl_prop("max_speed") == pytest.approx(0.5)
    assert pos.capable(c.MsgType.CMD, c.PLAYER_POSITION2D_CMD_VEL)
    assert not pos.capable(c.MsgType.REQ, 200)
    with pytest.raises(PlayerNack):
        laser.request(c.PLAYER_LASER_REQ_SET_FILTER)
    with pytest.raises(PlayerNack):
        pos.get_int_prop("no_such_property")


def test_simulation_get_and_set_pose(client: PlayerClient) -> None:
    sim = client.subscribe(SimulationProxy)
    sim.set_pose2d("box1", 1.0, 1.0, 0.5)
    client.subscribe(PowerProxy)
    client.read()
    client.read()
    x, y, yaw = sim.get_pose2d("box1")
    assert (x, y, yaw) == pytest.approx((1.0, 1.0, 0.5), abs=0.02)
    pose3d, simtime = sim.get_pose3d("box1")
    assert pose3d.px == pytest.approx(1.0, abs=0.02) and simtime > 0
    with pytest.raises(PlayerNack):
        sim.get_pose2d("no_such_thing")


def test_unknown_and_unsubscribed_devices_are_nacked(client: PlayerClient) -> None:
    with pytest.raises(PlayerNack):
        client.subscribe(LaserProxy, index=3)
    with pytest.raises(PlayerNack):
        client.request(6, 0, c.PLAYER_LASER_REQ_GET_GEOM)  # not subscribed
    laser = client.subscribe(LaserProxy)
    client.unsubscribe(laser)
    with pytest.raises(PlayerNack):
        laser.get_geometry()


def test_push_mode(server: PlayerServer) -> None:
    with PlayerClient("127.0.0.1", server.ports["robot1"], mode=c.PLAYER_DATAMODE_PUSH) as cl:
        pos = cl.subscribe(Position2dProxy)
        times = []
        for _ in range(5):
            assert cl.read() == [pos]
            times.append(pos.data_time_s)
        assert times == sorted(times) and times[-1] > times[0]


def test_camera_jpeg(client: PlayerClient) -> None:
    cam = client.subscribe(CameraProxy)
    cam.set_compression(True)
    client.read()
    assert cam.compressed and cam.image[:2] == b"\xff\xd8"
    assert cam.get_image().width == 160


def test_overhead_camera_port(server: PlayerServer) -> None:
    with PlayerClient("127.0.0.1", server.ports["overhead"]) as cl:
        blobs = cl.subscribe(BlobfinderProxy)
        fid = cl.subscribe(FiducialProxy)
        cam = cl.subscribe(CameraProxy)
        cl.read()
        assert blobs.width > 0 and len(blobs.blobs) >= 3
        assert 7 in {f.id for f in fid.fiducials}  # green_can
        assert len(cam.image) == cam.width * cam.height * 3 == blobs.width * blobs.height * 3
        red = next(b for b in blobs.blobs if b.color == 0xFF0000)  # red_can
        i = (red.y * cam.width + red.x) * 3
        assert cam.image[i:i + 3] == b"\xff\x00\x00"  # drawn where the blob is
        with pytest.raises(PlayerNack):
            cl.subscribe(Position2dProxy)


def _raw_connect(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    assert len(s.recv(32)) == 32
    return s


def _closed_by_server(s: socket.socket) -> bool:
    s.settimeout(5)
    try:
        while True:
            if not s.recv(65536):
                return True
    except (ConnectionResetError, BrokenPipeError):
        return True
    except TimeoutError:
        return False


def test_malformed_and_oversize_frames(server: PlayerServer, client: PlayerClient) -> None:
    port = server.ports["robot1"]
    laser = client.subscribe(LaserProxy)
    client.read()
    # a body that does not decode: answered with a NACK, connection stays
    raw = _raw_connect(port)
    raw.sendall(struct.pack(">IIIIIIdII", 0, 0, 1, 0, 3, 3, 0.0, 0, 4) + b"\0\0\0\1"
                + encode_message(1, 0, 3, c.PLAYER_REQ_DEVLIST))
    raw.settimeout(5)
    data = b""
    while len(data) < 80:
        data += raw.recv(65536)
    assert struct.unpack(">IIIIII", data[:24])[4:] == (c.MsgType.RESP_NACK, 3)
    assert struct.unpack(">IIIIII", data[40:64])[4:] == (c.MsgType.RESP_ACK, 1)
    raw.close()
    # an oversize frame: the connection is closed
    raw = _raw_connect(port)
    raw.sendall(struct.pack(">IIIIIIdII", 0, 0, 4, 0, 2, 1, 0.0, 0, 64 * 1024 * 1024))
    assert _closed_by_server(raw)
    raw.close()
    # others carry on
    client.read()
    assert len(laser.ranges) == 181
    assert server.core.counters.sessions_closed_bad_input >= 1


def test_a_client_that_stops_reading_stalls_nobody(server: PlayerServer,
                                                   client: PlayerClient) -> None:
    port = server.ports["robot1"]
    stuck = PlayerClient("127.0.0.1", port, mode=c.PLAYER_DATAMODE_PUSH).connect()
    try:
        stuck.subscribe(CameraProxy)  # big images, pushed every tick, never read
        stuck.subscribe(LaserProxy)
        pos = client.subscribe(Position2dProxy)
        t0 = None
        for _ in range(30):
            client.read()
            assert t0 is None or pos.data_time_s > t0  # type: ignore[operator]
            t0 = pos.data_time_s
        s = [x for x in server.core.sessions.values() if x.mode == c.PLAYER_DATAMODE_PUSH]
        assert s and all(len(x.queue) <= 4 for x in s)  # latest value replaces stale data
    finally:
        stuck.close()


def test_connection_refused_is_clear() -> None:
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    sock.close()
    with pytest.raises(PlayerConnectionError, match="cannot connect"):
        PlayerClient("127.0.0.1", port, timeout_s=1.0).connect()


def test_paused_server_serves_rounds_without_time_passing() -> None:
    with serve("simple", speedup=0.0, paused=True) as srv, \
            PlayerClient("127.0.0.1", srv.ports["robot1"]) as cl:
        pos = cl.subscribe(Position2dProxy)
        stamps = []
        for _ in range(5):
            cl.read()
            stamps.append(pos.data_time_s)
        assert stamps == [0.0] * 5 and pos.data_count == 5
        sim = cl.subscribe(SimulationProxy)
        sim.pause()  # toggles: resume
        deadline = time.monotonic() + 20
        while pos.data_time_s == 0.0 and time.monotonic() < deadline:
            cl.read()
        assert pos.data_time_s > 0.0


def test_free_running_speedup_paces_time() -> None:
    with serve("simple", speedup=5.0) as srv, \
            PlayerClient("127.0.0.1", srv.ports["robot1"]) as cl:
        pos = cl.subscribe(Position2dProxy)
        cl.read()
        t_sim0, t0 = pos.data_time_s, time.monotonic()
        for _ in range(10):
            cl.read()
        advanced_s = pos.data_time_s - t_sim0  # type: ignore[operator]
        rate = advanced_s / (time.monotonic() - t0)
        # Paced at (at most) 5x: never as fast as possible. A loaded machine may lag behind the
        # pace, so only the upper bound is a property of the server.
        assert advanced_s > 0.0
        assert rate < 6.5
