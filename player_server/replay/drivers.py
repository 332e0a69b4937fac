"""Drivers that serve recorded data: position2d, laser, sonar, power and blobfinder.

Each one answers with the newest message of its channel at the replay's time, and its
geometry requests from the recorded world. Commands are taken and ignored (counted), and the
configuration requests a live device would act on are acknowledged, as Player's readlog does.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack
from player_server.drivers.ranging import LASER_SIZE
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d, Pose2d, Pose3d
from player_server.protocol.constants import Interface
from player_server.record import channels as ch
from player_server.replay.source import Latest, RecordedRun


def _pose3d(m: Sequence[float]) -> Pose3d:
    x, y, z, yaw = (float(v) for v in m)
    return Pose3d(x, y, z, 0.0, 0.0, yaw)


def _ranges(values: Any) -> tuple[float, ...]:
    return tuple(float(v) if isinstance(v, int | float) and v >= 0.0 else 0.0 for v in values)


class ReplayDriver(Driver):
    """The newest message of one recorded channel, made into a DATA body once."""

    channel = ""

    def __init__(self, run: RecordedRun, robot: str, index: int = 0) -> None:
        super().__init__(index, f"readlog_{type(self).__name__.lower()}")
        self.run = run
        self.robot = robot
        self.spec = run.robots[robot]
        self.ignored_commands = 0
        self._made: tuple[Latest | None, Sequence[tuple[int, Any]]] = (None, ())

    def data(self) -> Sequence[tuple[int, Any]]:
        latest = self.run.latest(self.robot, self.channel)
        if latest is None:
            return ()
        made_from, made = self._made
        if latest is not made_from:
            try:
                made = self.make(latest.message)
            except (KeyError, TypeError, ValueError):
                made = ()  # a message that does not fit: nothing new to serve
            self._made = (latest, made)
        return made

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        raise NotImplementedError

    def handle_command(self, subtype: int, body: Any) -> None:
        self.ignored_commands += 1  # a recording cannot be driven


class ReplayPosition2d(ReplayDriver):
    interf = int(Interface.POSITION2D)
    channel = ch.ODOMETRY
    commands = frozenset({1, 2, 3, 4})
    deferred_commands = commands
    requests = frozenset(range(1, 10))

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_POSITION2D_DATA_STATE, am.Position2dData(
            Pose2d(float(m["x"]), float(m["y"]), float(m["yaw"])),
            Pose2d(float(m["vx"]), float(m["vy"]), float(m["vyaw"])),
            1 if m["stall"] else 0)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_POSITION2D_REQ_GET_GEOM:
            b = self.spec["body"]
            return ack(am.Position2dGeom(
                Pose3d(float(b["offset_x"]), 0.0, float(b["height"]) / 2, 0.0, 0.0, 0.0),
                Bbox3d(float(b["width"]), float(b["length"]), float(b["height"]))))
        if body is not None:
            return ACK  # motor power, odometry and mode changes: taken, not acted on
        raise Unsupported(f"position2d request {subtype}")


class ReplayLaser(ReplayDriver):
    interf = int(Interface.LASER)
    channel = ch.LASER
    requests = frozenset({1, 2, 3, 4, 5})

    def __init__(self, run: RecordedRun, robot: str, index: int = 0) -> None:
        super().__init__(run, robot, index)
        self.laser = self.spec["devices"]["laser"]

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        s = self.laser
        ranges = _ranges(m["ranges"])
        lo, hi = float(m["start_angle"]), float(m["end_angle"])
        res = (hi - lo) / max(len(ranges) - 1, 1)
        ts = m["timestamp"]
        scan_id = round((int(ts["sec"]) + int(ts["nsec"]) / 1e9) / self.run.interval_s)
        return ((c.PLAYER_LASER_DATA_SCAN, sm.LaserData(
            lo, hi, res, float(s["max_range"]), ranges, b"", scan_id & 0xFFFFFFFF)),)

    def config(self) -> sm.LaserConfig:
        s = self.laser
        return sm.LaserConfig(float(s["min_angle"]), float(s["max_angle"]),
                              float(s["resolution"]), float(s["max_range"]),
                              float(s["range_res"]), 0, float(s["frequency"]))

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_LASER_REQ_GET_GEOM:
            return ack(sm.LaserGeom(_pose3d(self.laser["pose"]), LASER_SIZE))
        if subtype in (c.PLAYER_LASER_REQ_GET_CONFIG, c.PLAYER_LASER_REQ_SET_CONFIG):
            return ack(self.config())
        if subtype == c.PLAYER_LASER_REQ_POWER and body is not None:
            return ACK
        if subtype == c.PLAYER_LASER_REQ_GET_ID:
            return ack(sm.LaserGetIdConfig(0))
        raise Unsupported(f"laser request {subtype}")


class ReplaySonar(ReplayDriver):
    interf = int(Interface.SONAR)
    channel = ch.SONAR_RANGES
    requests = frozenset({c.PLAYER_SONAR_REQ_GET_GEOM, c.PLAYER_SONAR_REQ_POWER})

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_SONAR_DATA_RANGES, sm.SonarData(_ranges(m["ranges"]))),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_SONAR_REQ_GET_GEOM:
            poses = self.spec["devices"]["sonar"]["poses"]
            return ack(sm.SonarGeom(tuple(_pose3d(p) for p in poses)))
        if subtype == c.PLAYER_SONAR_REQ_POWER and body is not None:
            return ACK
        raise Unsupported(f"sonar request {subtype}")


_VALID_ALL = (c.PLAYER_POWER_MASK_VOLTS | c.PLAYER_POWER_MASK_WATTS | c.PLAYER_POWER_MASK_JOULES
              | c.PLAYER_POWER_MASK_PERCENT | c.PLAYER_POWER_MASK_CHARGING)


class ReplayPower(ReplayDriver):
    interf = int(Interface.POWER)
    channel = ch.BATTERY
    requests = frozenset({c.PLAYER_POWER_REQ_SET_CHARGING_POLICY})

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_POWER_DATA_STATE, am.PowerData(
            _VALID_ALL, float(m["volts"]), float(m["percent"]), float(m["joules"]),
            -abs(float(m["watts"])), 1 if m["charging"] else 0)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_POWER_REQ_SET_CHARGING_POLICY and body is not None:
            return ACK
        raise Unsupported(f"power request {subtype}")


def _u32(v: Any) -> int:
    return max(int(v), 0) & 0xFFFFFFFF


class ReplayBlobfinder(ReplayDriver):
    interf = int(Interface.BLOBFINDER)
    channel = ch.BLOBS

    def make(self, m: Any) -> Sequence[tuple[int, Any]]:
        blobs = tuple(
            sm.BlobfinderBlob(_u32(b[0]), _u32(b[1]) & 0xFFFFFF, _u32(b[2]), _u32(b[3]),
                              _u32(b[4]), _u32(b[5]), _u32(b[6]), _u32(b[7]), _u32(b[8]),
                              float(b[9]))
            for b in m["blobs"])
        return ((c.PLAYER_BLOBFINDER_DATA_BLOBS,
                 sm.BlobfinderData(_u32(m["width"]), _u32(m["height"]), blobs)),)


_BY_CHANNEL: dict[str, type[ReplayDriver]] = {
    ch.ODOMETRY: ReplayPosition2d, ch.LASER: ReplayLaser, ch.SONAR_RANGES: ReplaySonar,
    ch.BATTERY: ReplayPower, ch.BLOBS: ReplayBlobfinder,
}


def replay_drivers(run: RecordedRun, robot: str) -> dict[tuple[int, int], Driver]:
    """One driver per device recorded for the robot."""
    drivers = [cls(run, robot) for channel, cls in _BY_CHANNEL.items()
               if channel in run.recorded(robot)]
    return {(d.interf, d.index): d for d in drivers}
