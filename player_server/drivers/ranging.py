"""Range sensors: sonar, laser and ranger."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack, declared
from player_server.drivers.geometry import mount_pose
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec


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


#: how far (in readings) a requested angle may lie from one of the laser's own
_ANGLE_TOLERANCE = 1e-3

_MAKE_SONAR = sm.SonarData.xdr_make  # type: ignore[attr-defined]
_MAKE_LASER = sm.LaserData.xdr_make  # type: ignore[attr-defined]


class SonarDriver(Driver):
    interf = int(Interface.SONAR)
    requests = frozenset({c.PLAYER_SONAR_REQ_GET_GEOM, c.PLAYER_SONAR_REQ_POWER})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_sonar")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.sonar, f"robot {robot.name!r}", "sonar")
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


@dataclass(frozen=True)
class LaserWindow:
    """What SET_CONFIG chose of the simulated scan: readings ``first``..``last`` (indices
    into the full scan) every ``step``-th, clipped to ``max_range_m``."""

    first: int
    last: int
    step: int
    max_range_m: float


def laser_window(spec: Any, cfg: sm.LaserConfig) -> LaserWindow:
    """The window a SET_CONFIG asks for, or ValueError naming what the simulated laser
    cannot do. It can narrow the scan to whole readings of its own, take every n-th reading
    and shorten its range; it cannot scan finer, wider, further, at another range
    resolution or rate, or report intensities."""
    res = float(spec.resolution_rad)
    n = int(spec.samples)
    values = (cfg.min_angle, cfg.max_angle, cfg.resolution, cfg.max_range, cfg.range_res,
              cfg.scanning_frequency)
    if not all(math.isfinite(v) for v in values):
        raise ValueError("laser config values must be finite")

    def index(angle: float, what: str) -> int:
        x = (angle - float(spec.min_angle_rad)) / res
        i = round(x)
        if abs(x - i) > _ANGLE_TOLERANCE or not 0 <= i < n:
            raise ValueError(f"{what} {angle:.6g} rad is not one of the laser's readings "
                             f"({spec.min_angle_rad:.6g} to {spec.max_angle_rad:.6g} rad "
                             f"every {res:.6g} rad)")
        return i

    first = index(cfg.min_angle, "min_angle")
    last = index(cfg.max_angle, "max_angle")
    if last < first:
        raise ValueError("max_angle is below min_angle")
    step_f = cfg.resolution / res
    step = round(step_f)
    if step < 1 or abs(step_f - step) > _ANGLE_TOLERANCE or (last - first) % step:
        raise ValueError(f"resolution {cfg.resolution:.6g} rad is not a whole multiple of "
                         f"{res:.6g} rad that spans min_angle..max_angle")
    if not 0.0 < cfg.max_range <= float(spec.max_range_m) * (1 + 1e-6):
        raise ValueError(f"max_range {cfg.max_range:g} m is outside (0, {spec.max_range_m:g}]")
    if abs(cfg.range_res - float(spec.range_res_m)) > 1e-6 * max(1.0, spec.range_res_m):
        raise ValueError(f"range_res is fixed at {spec.range_res_m:g} m")
    if cfg.intensity:
        raise ValueError("the simulated laser reports no intensities")
    if abs(cfg.scanning_frequency - float(spec.frequency_hz)) > 1e-3:
        raise ValueError(f"scanning_frequency is fixed at {spec.frequency_hz:g} Hz")
    return LaserWindow(first, last, step, min(float(cfg.max_range), float(spec.max_range_m)))


class LaserDriver(Driver):
    """The scanning laser. SET_CONFIG applies what ``laser_window`` accepts and is NACKed
    otherwise; GET_CONFIG and the DATA follow the configuration in force."""

    interf = int(Interface.LASER)
    requests = frozenset({1, 2, 3, 4, 5})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0,
                 serial_number: int = 0) -> None:
        super().__init__(index, "sim_laser")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.laser, f"robot {robot.name!r}", "laser")
        self.serial_number = serial_number
        self.powered = True
        self.properties = {"max_range": float(self.spec.max_range_m)}
        self.property_limits = {"max_range": (0.0, float(self.spec.max_range_m))}
        self._geom = sm.LaserGeom(mount_pose(self.spec.pose), LASER_SIZE)
        self.window: LaserWindow | None = None  # None: the whole scan as the world gives it
        self._last: tuple[Any, tuple[float, ...]] = (None, ())  # reading, its ranges

    def config(self) -> sm.LaserConfig:
        s, w = self.spec, self.window
        if w is None:
            return sm.LaserConfig(s.min_angle_rad, s.max_angle_rad, s.resolution_rad,
                                  s.max_range_m, s.range_res_m, 0, s.frequency_hz)
        return sm.LaserConfig(s.min_angle_rad + w.first * s.resolution_rad,
                              s.min_angle_rad + w.last * s.resolution_rad,
                              s.resolution_rad * w.step, w.max_range_m, s.range_res_m, 0,
                              s.frequency_hz)

    def _windowed(self, ranges: tuple[float, ...]) -> tuple[float, ...]:
        w = self.window
        if w is None or len(ranges) != self.spec.samples:
            return ranges
        cut = ranges[w.first:w.last + 1:w.step]
        top = w.max_range_m
        return tuple(r if r <= top else top for r in cut)

    def data(self) -> Sequence[tuple[int, Any]]:
        s = self.spec
        reading = self.sim.laser(self.robot.name)
        last_in, ranges = self._last
        if reading is not last_in:  # (the scan's id changes every tick, its ranges may not)
            ranges = self._windowed(_ranges(reading))
            self._last = (reading, ranges)
        if self.window is not None:
            cfg = self.config()
            return ((c.PLAYER_LASER_DATA_SCAN, _MAKE_LASER(
                cfg.min_angle, cfg.max_angle, cfg.resolution, cfg.max_range, ranges, b"",
                int(self.sim.tick) & 0xFFFFFFFF)),)
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
            window = laser_window(self.spec, body)  # ValueError: NACKed, nothing changed
            s = self.spec
            whole = (window.first == 0 and window.last == s.samples - 1 and window.step == 1
                     and window.max_range_m >= s.max_range_m)
            self.window = None if whole else window
            self._last = (None, ())
            return ack(self.config())
        if subtype == c.PLAYER_LASER_REQ_POWER and body is not None:
            self.powered = bool(body.state)
            return ACK
        if subtype == c.PLAYER_LASER_REQ_GET_ID:
            return ack(sm.LaserGetIdConfig(self.serial_number))
        raise Unsupported(f"laser request {subtype}")


class RangerDriver(Driver):
    interf = int(Interface.RANGER)
    requests = frozenset({1, 2, 3, 4, 5})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_ranger")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.ranger, f"robot {robot.name!r}", "ranger")
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

