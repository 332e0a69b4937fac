"""Turning proxy values (decoded Player messages) into snapshots, without a socket."""

from __future__ import annotations

import math
import threading

from behaviors.sensing import FrameOffset, PlayerRobotIO
from behaviors.snapshot import Deferred, LazySnapshot, Snapshot
from player_server.client import (
    BlobfinderProxy,
    BumperProxy,
    LaserProxy,
    PlayerClient,
    Position2dProxy,
    PowerProxy,
    SonarProxy,
)
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Pose2d


def _io() -> tuple[PlayerRobotIO, dict[str, object]]:
    client = PlayerClient("127.0.0.1", 1)  # never connected
    io = PlayerRobotIO(client, camera_fov_rad=math.radians(60))
    proxies = {
        "position2d": Position2dProxy(client),
        "sonar": SonarProxy(client),
        "laser": LaserProxy(client),
        "blobfinder": BlobfinderProxy(client),
        "bumper": BumperProxy(client),
        "power": PowerProxy(client),
    }
    io.proxies.update(proxies)  # type: ignore[arg-type]
    return io, proxies


def test_empty_proxies_give_an_empty_snapshot() -> None:
    io, _ = _io()
    snap = io.snapshot(None)
    assert snap.odometry is None and snap.laser is None and snap.camera is None
    assert snap.power is None and snap.bumpers is None


def test_readings_carry_their_own_timestamps_and_rear_laser_bearings() -> None:
    io, p = _io()
    io._laser_pose = (-0.26, 0.0, math.pi)  # mounted facing backwards
    p["position2d"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_POSITION2D_DATA_STATE,
        am.Position2dData(Pose2d(1.0, 2.0, 0.5), Pose2d(0.2, 0.0, 0.1), 1), 3.0)
    p["laser"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_LASER_DATA_SCAN,
        sm.LaserData(-math.pi / 2, math.pi / 2, math.pi / 2, 8.0, (1.0, 2.0, 3.0), b"", 7), 3.1)
    blob = sm.BlobfinderBlob(0, 0xFF8000, 50, 80, 60, 70, 90, 50, 70, 2.5)
    p["blobfinder"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_BLOBFINDER_DATA_BLOBS, sm.BlobfinderData(160, 120, (blob,)), 2.9)
    p["bumper"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_BUMPER_DATA_STATE, sm.BumperData(b"\x00\x01"), 3.0)
    p["power"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_POWER_DATA_STATE, am.PowerData(31, 12.0, 55.0, 1000.0, -20.0, 1), 3.0)
    io._bumper_front = (True, False)
    snap = io.snapshot(None)
    assert snap.pose is not None and (snap.pose.x_m, snap.pose.y_m) == (1.0, 2.0)
    assert snap.odometry is not None and snap.odometry.stall and snap.odometry.time_s == 3.0
    assert snap.laser is not None and snap.laser.time_s == 3.1 and snap.laser.scan_id == 7
    # Bearings are in the robot frame: the middle reading points straight back.
    assert abs(abs(snap.laser.bearings_rad[1]) - math.pi) < 1e-9
    assert abs(snap.laser.bearings_rad[0] - math.pi / 2) < 1e-9  # first reading: left
    assert snap.camera is not None and snap.camera.blobs[0].colour == 0xFF8000
    assert snap.camera.time_s == 2.9 and snap.camera.fov_rad == math.radians(60)
    assert snap.bumpers is not None and snap.bumpers.any_pressed
    assert not snap.bumpers.front_pressed  # only the rear panel is pressed
    assert snap.power is not None and snap.power.charging == 1 and snap.power.percent == 55.0
    # Unchanged devices are not rebuilt.
    again = io.snapshot(None)
    assert again.laser is snap.laser and again.camera is snap.camera


def test_sonar_without_geometry_and_odometry_offset() -> None:
    io, p = _io()
    p["sonar"]._on_data(c.PLAYER_SONAR_DATA_RANGES, sm.SonarData((1.0,) * 4), 1.0)  # type: ignore[attr-defined]
    snap = io.snapshot(None)
    assert snap.sonar is not None and len(snap.sonar.bearings_rad) == 4
    io.odometry_offset = FrameOffset(1.0, 0.0, math.pi / 2)
    p["position2d"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_POSITION2D_DATA_STATE, am.Position2dData(Pose2d(1.0, 0.0, 0.0), Pose2d(), 0), 1.0)
    pose = io.snapshot(None).pose
    assert pose is not None
    assert abs(pose.x_m - 1.0) < 1e-9 and abs(pose.y_m - 1.0) < 1e-9
    assert abs(pose.yaw_rad - math.pi / 2) < 1e-9


def test_deferred_readings_are_built_once_from_the_data_of_their_round() -> None:
    io, p = _io()
    scan = sm.LaserData(-1.0, 1.0, 1.0, 8.0, (1.0, 2.0, 3.0), b"", 1)
    p["laser"]._on_data(c.PLAYER_LASER_DATA_SCAN, scan, 1.0)  # type: ignore[attr-defined]
    p["position2d"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_POSITION2D_DATA_STATE, am.Position2dData(Pose2d(1.0, 0.0, 0.0), Pose2d(), 0), 1.0)
    old = io.snapshot(None)
    assert isinstance(old, LazySnapshot)
    assert all(type(Snapshot.__dict__[f].__get__(old)) is Deferred for f in ("laser", "odometry"))
    # new data arrives before anyone looked at the old round: the old snapshot keeps its own
    p["laser"]._on_data(  # type: ignore[attr-defined]
        c.PLAYER_LASER_DATA_SCAN, sm.LaserData(-1.0, 1.0, 1.0, 8.0, (5.0,) * 3, b"", 2), 2.0)
    new = io.snapshot(None)
    seen: list[object] = []
    reader = threading.Thread(target=lambda: seen.append(old.laser))
    reader.start()
    reader.join(5)
    assert old.laser is seen[0] and old.laser is not None and old.laser.ranges_m == (1.0, 2.0, 3.0)
    assert new.laser is not None and new.laser.ranges_m == (5.0,) * 3 and new.laser.scan_id == 2
    assert new.odometry is old.odometry  # position2d sent nothing new: the same reading
    marked = new.with_mark(None)
    assert marked == new and marked.laser is new.laser
    plain = Snapshot(new.time_s, new.odometry, new.sonar, new.laser, new.camera, new.bumpers,
                     new.power, new.gripper, new.mark)
    assert new == plain and plain == new and hash(new) == hash(plain)
