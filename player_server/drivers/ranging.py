"""Range sensors: sonar, laser and ranger."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from player_server.drivers.base import (
    ACK,
    Driver,
    PropValue,
    Reply,
    Unsupported,
    ack,
    declared,
)
from player_server.drivers.geometry import mount_pose
from player_server.drivers.scan_config import ConfiguredScan, ScanRequest
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d, Pose3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import LaserSpec, RangerSpec, RobotSpec, SonarSpec


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


def max_range_property(
    max_range_m: float,
) -> tuple[dict[str, PropValue], dict[str, tuple[float, float]]]:
    """A range sensor's universal properties and their limits: "max_range", its own range,
    which a client may set from 0 up to that."""
    top = float(max_range_m)
    return {"max_range": top}, {"max_range": (0.0, top)}


def apply_scan(sim: SimPort, robot: RobotSpec, source: str, scan: ConfiguredScan,
               request: ScanRequest) -> None:
    """Put a SET_CONFIG in force (ValueError: NACKed, nothing changed) and have the
    simulation cast the scanner's rays over the fan it configures."""
    scan.set(request)
    sim.set_scan_fan(robot.name, source, scan.config.fan)


_MAKE_SONAR = sm.SonarData.xdr_make  # type: ignore[attr-defined]
_MAKE_LASER = sm.LaserData.xdr_make  # type: ignore[attr-defined]


class RangeSensorDriver(Driver):
    """A robot's range sensor: its description in the world file (``source`` names the
    device there: "sonar", "laser" or "ranger") and its "max_range" property."""

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int, driver_name: str,
                 source: str) -> None:
        super().__init__(index, driver_name)
        self.sim = sim
        self.robot = robot
        self.source = source
        self.spec = declared(getattr(robot.devices, source), f"robot {robot.name!r}", source)
        self.properties, self.property_limits = max_range_property(self.spec.max_range_m)


class SonarDriver(RangeSensorDriver):
    device = "sonar"
    interf = int(Interface.SONAR)
    requests = frozenset({c.PLAYER_SONAR_REQ_GET_GEOM, c.PLAYER_SONAR_REQ_POWER})
    spec: SonarSpec

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(sim, robot, index, "sim_sonar", "sonar")
        self.powered = True
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


def scan_request(cfg: Any) -> ScanRequest:
    """A laser or ranger SET_CONFIG body as a `ScanRequest` (the ranger has no intensity
    field: its INTNS request switches them)."""
    if isinstance(cfg, sm.RangerConfig):
        return ScanRequest(cfg.min_angle, cfg.max_angle, cfg.angular_res, cfg.max_range,
                           cfg.range_res, False, cfg.frequency)
    return ScanRequest(cfg.min_angle, cfg.max_angle, cfg.resolution, cfg.max_range,
                       cfg.range_res, bool(cfg.intensity), cfg.scanning_frequency)


class ScannerDriver(RangeSensorDriver):
    """A scanning range sensor (a laser, or a ranger over a laser or ranger): its fixed
    geometry (GET_GEOM) and the scan configuration in force, which a client reads
    (GET_CONFIG) and sets (SET_CONFIG: what `scan_config` accepts, NACKed otherwise)."""

    #: the REQ subtypes of GET_GEOM, GET_CONFIG and SET_CONFIG in the driver's interface
    scan_requests: ClassVar[tuple[int, int, int]]
    spec: LaserSpec | RangerSpec

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int, driver_name: str,
                 source: str, scan: ConfiguredScan | None) -> None:
        super().__init__(sim, robot, index, driver_name, source)
        self.scan = scan or ConfiguredScan(self.spec, float(sim.spec.sim.interval_sim_s))
        self._geom = self.geometry()

    def geometry(self) -> Any:
        """The GET_GEOM reply."""
        raise NotImplementedError

    def config(self) -> Any:
        """The configuration in force, as the interface's config body."""
        raise NotImplementedError

    def requested_scan(self, body: Any) -> ScanRequest:
        """What a SET_CONFIG body asks for."""
        return scan_request(body)

    def scan_reply(self, subtype: int, body: Any) -> Reply | None:
        """The answer to GET_GEOM, GET_CONFIG or SET_CONFIG; None for any other request."""
        get_geom, get_config, set_config = self.scan_requests
        if subtype == get_geom:
            return ack(self._geom)
        if subtype == get_config:
            return ack(self.config())
        if subtype == set_config and body is not None:
            apply_scan(self.sim, self.robot, self.source, self.scan, self.requested_scan(body))
            return ack(self.config())
        return None


class LaserDriver(ScannerDriver):
    """The scanning laser. SET_CONFIG applies what `scan_config` accepts and is NACKed
    otherwise; GET_CONFIG and the DATA follow the configuration in force."""

    device = "laser"
    interf = int(Interface.LASER)
    requests = frozenset({1, 2, 3, 4, 5})
    scan_requests = (c.PLAYER_LASER_REQ_GET_GEOM, c.PLAYER_LASER_REQ_GET_CONFIG,
                     c.PLAYER_LASER_REQ_SET_CONFIG)

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0,
                 serial_number: int = 0, scan: ConfiguredScan | None = None) -> None:
        super().__init__(sim, robot, index, "sim_laser", "laser", scan)
        self.serial_number = serial_number
        self.powered = True
        self._last: tuple[Any, tuple[float, ...]] = (None, ())  # reading, its ranges

    def geometry(self) -> sm.LaserGeom:
        return sm.LaserGeom(mount_pose(self.spec.pose), LASER_SIZE)

    def config(self) -> sm.LaserConfig:
        lo, hi, res, top, rr, freq = self.scan.reported()
        return sm.LaserConfig(lo, hi, res, top, rr, int(self.scan.config.intensity), freq)

    def data(self) -> Sequence[tuple[int, Any]]:
        s = self.spec
        reading = self.sim.laser(self.robot.name)
        tick = int(self.sim.tick)
        if not self.scan.is_whole:
            ranges, intens = self.scan.serve(reading, tick, _ranges)
            lo, hi, res = self.scan.angles()
            return ((c.PLAYER_LASER_DATA_SCAN, _MAKE_LASER(
                lo, hi, res, self.scan.config.max_range_m, ranges, intens,
                tick & 0xFFFFFFFF)),)
        last_in, ranges = self._last
        if reading is not last_in:  # (the scan's id changes every tick, its ranges may not)
            ranges = _ranges(reading)
            self._last = (reading, ranges)
        res = s.resolution_rad if len(ranges) == s.samples else (
            (s.max_angle_rad - s.min_angle_rad) / max(len(ranges) - 1, 1))
        return ((c.PLAYER_LASER_DATA_SCAN, _MAKE_LASER(
            s.min_angle_rad, s.max_angle_rad, res, s.max_range_m, ranges, b"",
            tick & 0xFFFFFFFF)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        reply = self.scan_reply(subtype, body)
        if reply is not None:
            return reply
        if subtype == c.PLAYER_LASER_REQ_POWER and body is not None:
            self.powered = bool(body.state)
            return ACK
        if subtype == c.PLAYER_LASER_REQ_GET_ID:
            return ack(sm.LaserGetIdConfig(self.serial_number))
        raise Unsupported(f"laser request {subtype}")

class RangerDriver(ScannerDriver):
    """The ranger interface over a scanner: the world's ranger, or (``source="laser"``) a
    robot's laser, as Stage serves its lasers. SET_CONFIG works as the laser's does (the
    angular resolution in radians); INTNS switches intensity DATA on and off."""

    device = "ranger"
    interf = int(Interface.RANGER)
    requests = frozenset({1, 2, 3, 4, 5})
    scan_requests = (c.PLAYER_RANGER_REQ_GET_GEOM, c.PLAYER_RANGER_REQ_GET_CONFIG,
                     c.PLAYER_RANGER_REQ_SET_CONFIG)

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0, *,
                 source: str = "ranger", scan: ConfiguredScan | None = None) -> None:
        super().__init__(sim, robot, index, "sim_ranger", source, scan)
        self._read = sim.laser if source == "laser" else sim.ranger

    def config(self) -> sm.RangerConfig:
        lo, hi, res = self.scan.angles()
        cfg = self.scan.config
        freq = self.scan.reported()[5]
        return sm.RangerConfig(lo, hi, res, float(self.spec.min_range_m), cfg.max_range_m,
                               cfg.range_res_m, freq)

    def geometry(self) -> sm.RangerGeom:
        pose = mount_pose(self.spec.pose)
        return sm.RangerGeom(pose, LASER_SIZE, (pose,), (LASER_SIZE,))

    def data(self) -> Sequence[tuple[int, Any]]:
        reading = self._read(self.robot.name)
        if self.scan.is_whole:
            return ((c.PLAYER_RANGER_DATA_RANGE, sm.RangerDataRange(_ranges(reading))),)
        ranges, intens = self.scan.serve(reading, int(self.sim.tick), _ranges)
        out: tuple[tuple[int, Any], ...] = (
            (c.PLAYER_RANGER_DATA_RANGE, sm.RangerDataRange(ranges)),)
        if intens:
            out += ((c.PLAYER_RANGER_DATA_INTNS,
                     sm.RangerDataIntns(tuple(float(b) for b in intens))),)
        return out

    def requested_scan(self, body: Any) -> ScanRequest:
        """As the laser's, keeping the intensity setting (INTNS switches it)."""
        return replace(scan_request(body), intensity=self.scan.config.intensity)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        reply = self.scan_reply(subtype, body)
        if reply is not None:
            return reply
        if subtype == c.PLAYER_RANGER_REQ_INTNS and body is not None:
            self.scan.set_intensity(bool(body.state))
            return ACK
        if subtype == c.PLAYER_RANGER_REQ_POWER and body is not None:
            return ACK
        raise Unsupported(f"ranger request {subtype}")


class SonarRangerDriver(RangeSensorDriver):
    """The ranger interface over a sonar array (Stage serves its sonars as rangers): one
    reading per transducer, each element's pose in the geometry. Its configuration is
    fixed: SET_CONFIG is ACKed only when it asks for what is in force (fields left zero keep
    it)."""

    interf = int(Interface.RANGER)
    requests = frozenset({1, 2, 4, 5})
    spec: SonarSpec

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(sim, robot, index, "sim_ranger", "sonar")
        poses = tuple(mount_pose(m) for m in self.spec.poses)
        self._geom = sm.RangerGeom(Pose3d(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), SONAR_SIZE, poses,
                                   tuple(SONAR_SIZE for _ in poses))
        self._last: tuple[Any, Any] = (None, None)

    def config(self) -> sm.RangerConfig:
        s = self.spec
        return sm.RangerConfig(-s.cone_rad / 2, s.cone_rad / 2, 0.0, s.min_range_m,
                               s.max_range_m, 0.001, 1.0 / float(self.sim.spec.sim.interval_sim_s))

    def data(self) -> Sequence[tuple[int, Any]]:
        reading = self.sim.sonar(self.robot.name)
        last_in, body = self._last
        if reading is not last_in:
            body = sm.RangerDataRange(_ranges(reading))
            self._last = (reading, body)
        return ((c.PLAYER_RANGER_DATA_RANGE, body),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_RANGER_REQ_GET_GEOM:
            return ack(self._geom)
        if subtype == c.PLAYER_RANGER_REQ_GET_CONFIG:
            return ack(self.config())
        if subtype == c.PLAYER_RANGER_REQ_SET_CONFIG and body is not None:
            now = self.config()
            fields = ("min_angle", "max_angle", "angular_res", "min_range", "max_range")
            asked = [(getattr(body, f), getattr(now, f)) for f in fields]
            # fields left zero (or NaN) keep what is in force, as for the laser
            if any(math.isfinite(a) and a != 0.0 and abs(a - b) > 1e-6 for a, b in asked):
                raise ValueError("the sonar array's configuration is fixed")
            return ack(now)
        if subtype == c.PLAYER_RANGER_REQ_POWER and body is not None:
            return ACK
        raise Unsupported(f"ranger request {subtype}")
