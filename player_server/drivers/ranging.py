"""Range sensors: sonar, laser and ranger."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack
from player_server.drivers.geometry import mount_pose
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d
from player_server.protocol.constants import Interface

LASER_SIZE = Bbox3d(0.155, 0.185, 0.2)  # SICK LMS200 housing, w x l x h
SONAR_SIZE = Bbox3d(0.04, 0.02, 0.04)


def _ranges(values: Any) -> tuple[float, ...]:
    """Plain non-negative floats (libplayerc asserts ranges >= 0; NaN becomes 0)."""
    out = values.tolist() if isinstance(values, np.ndarray) else [float(v) for v in values]
    if out:
        total = sum(out)
        # the sum is finite only if every value is, so one pass checks the usual case
        if total - total == 0.0 and min(out) >= 0.0:
            return tuple(out)
    return tuple(v if v >= 0.0 and v - v == 0.0 else 0.0 for v in out)


_MAKE_SONAR = sm.SonarData.xdr_make  # type: ignore[attr-defined]
_MAKE_LASER = sm.LaserData.xdr_make  # type: ignore[attr-defined]


class SonarDriver(Driver):
    interf = int(Interface.SONAR)
    requests = frozenset({c.PLAYER_SONAR_REQ_GET_GEOM, c.PLAYER_SONAR_REQ_POWER})

    def __init__(self, sim: Any, robot: Any, index: int = 0) -> None:
        super().__init__(index, "sim_sonar")
        self.sim = sim
        self.robot = robot
        self.spec = robot.devices.sonar
        self.powered = True
        self.properties = {"max_range": float(self.spec.max_range_m)}
        self.property_limits = {"max_range": (0.0, float(self.spec.max_range_m))}
        self._geom = self.geometry()
        # the last reading and what was made of it: the simulator hands back the same array
        # while the reading is unchanged, and then so does this driver
        self._last: tuple[Any, Any] = (None, None)

    def data(self) -> Sequence[tuple[int, Any]]:
        reading = self.sim.sonar(self.robot.name)
        last_in, body = self._last
        if reading is not last_in:
            body = _MAKE_SONAR(_ranges(reading))
            self._last = (reading, body)
        return ((c.PLAYER_SONAR_DATA_RANGES, body),)

    def geometry(self) -> sm.SonarGeom:
        return sm.SonarGeom(tuple(mount_pose(m) for m in self.spec.poses))

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_SONAR_REQ_GET_GEOM:
            return ack(self._geom)
        if subtype == c.PLAYER_SONAR_REQ_POWER and body is not None:
            self.powered = bool(body.state)
            return ACK
        raise Unsupported(f"sonar request {subtype}")


class LaserDriver(Driver):
    interf = int(Interface.LASER)
    requests = frozenset({1, 2, 3, 4, 5})

    def __init__(self, sim: Any, robot: Any, index: int = 0, serial_number: int = 0) -> None:
        super().__init__(index, "sim_laser")
        self.sim = sim
        self.robot = robot
        self.spec = robot.devices.laser
        self.serial_number = serial_number
        self.powered = True
        self.properties = {"max_range": float(self.spec.max_range_m)}
        self.property_limits = {"max_range": (0.0, float(self.spec.max_range_m))}
        self._geom = sm.LaserGeom(mount_pose(self.spec.pose), LASER_SIZE)
        self._last: tuple[Any, tuple[float, ...]] = (None, ())  # reading, its ranges

    def config(self) -> sm.LaserConfig:
        s = self.spec
        return sm.LaserConfig(s.min_angle_rad, s.max_angle_rad, s.resolution_rad,
                              s.max_range_m, s.range_res_m, 0, s.frequency_hz)

    def data(self) -> Sequence[tuple[int, Any]]:
        s = self.spec
        reading = self.sim.laser(self.robot.name)
        last_in, ranges = self._last
        if reading is not last_in:  # (the scan's id changes every tick, its ranges may not)
            ranges = _ranges(reading)
            self._last = (reading, ranges)
        res = s.resolution_rad if len(ranges) == s.samples else (
            (s.max_angle_rad - s.min_angle_rad) / max(len(ranges) - 1, 1))
        return ((c.PLAYER_LASER_DATA_SCAN, _MAKE_LASER(
            s.min_angle_rad, s.max_angle_rad, res, s.max_range_m, ranges, b"",
            int(self.sim.tick) & 0xFFFFFFFF)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_LASER_REQ_GET_GEOM:
            return ack(self._geom)
        if subtype == c.PLAYER_LASER_REQ_GET_CONFIG:
            return ack(self.config())
        if subtype == c.PLAYER_LASER_REQ_SET_CONFIG and body is not None:
            return ack(self.config())  # the scan geometry is fixed by the world
        if subtype == c.PLAYER_LASER_REQ_POWER and body is not None:
            self.powered = bool(body.state)
            return ACK
        if subtype == c.PLAYER_LASER_REQ_GET_ID:
            return ack(sm.LaserGetIdConfig(self.serial_number))
        raise Unsupported(f"laser request {subtype}")


class RangerDriver(Driver):
    interf = int(Interface.RANGER)
    requests = frozenset({1, 2, 3, 4, 5})

    def __init__(self, sim: Any, robot: Any, index: int = 0) -> None:
        super().__init__(index, "sim_ranger")
        self.sim = sim
        self.robot = robot
        self.spec = robot.devices.ranger
        self.properties = {"max_range": float(self.spec.max_range_m)}
        self.property_limits = {"max_range": (0.0, float(self.spec.max_range_m))}
        self._geom = self.geometry()

    def config(self) -> sm.RangerConfig:
        s = self.spec
        return sm.RangerConfig(s.min_angle_rad, s.max_angle_rad, s.resolution_rad,
                               s.min_range_m, s.max_range_m, s.range_res_m, s.frequency_hz)

    def geometry(self) -> sm.RangerGeom:
        pose = mount_pose(self.spec.pose)
        return sm.RangerGeom(pose, LASER_SIZE, (pose,), (LASER_SIZE,))

    def data(self) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_RANGER_DATA_RANGE,
                 sm.RangerDataRange(_ranges(self.sim.ranger(self.robot.name)))),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_RANGER_REQ_GET_GEOM:
            return ack(self._geom)
        if subtype in (c.PLAYER_RANGER_REQ_GET_CONFIG, c.PLAYER_RANGER_REQ_SET_CONFIG):
            return ack(self.config())  # SET answers with the resulting (fixed) config
        if subtype in (c.PLAYER_RANGER_REQ_POWER, c.PLAYER_RANGER_REQ_INTNS) and body is not None:
            return ACK
        raise Unsupported(f"ranger request {subtype}")

