"""Proxies for every interface the server offers (`PROXIES`); the drive and the range
sensors here, the other devices in `device_proxies`.

Each keeps its latest DATA body (``state``, ``scan``, ...) and typed accessors over it,
the geometry it last requested, and methods for the device's commands and requests.
Angles in radians, distances in metres, times in simulation seconds.

The bodies a robot reads every tick (position2d state, sonar ranges, laser scan,
blobfinder blobs, power state, bumpers) are taken from the receive buffer with one
precompiled ``struct`` call each, after checking that their counts and size agree, into
plain tuples (``state_values``, ``scan_values``, ``blob_values``, ``ranges``); the
message objects (``state``, ``scan``) are built from those only when read, once per
body. Anything else, and any body that does not pass the checks, goes through the
generic decoder.
"""

from __future__ import annotations

import math
import struct
from typing import Any

from player_server.client.device_proxies import (
    BlobfinderProxy,
    BumperProxy,
    CameraProxy,
    FiducialProxy,
    GripperProxy,
    ImuProxy,
    OpaqueProxy,
    PowerProxy,
    PtzProxy,
    SimulationProxy,
)
from player_server.client.proxy import Proxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Pose2d, Pose3d
from player_server.protocol.constants import Interface, MsgType
from player_server.protocol.errors import EncodeError
from player_server.protocol.header import HEADER_STRUCT
from player_server.protocol.xdr import COUNT_WORDS, WIRE_U32, wire_layout

_CMD = int(MsgType.CMD)
_COUNTS = COUNT_WORDS
_U32 = struct.Struct(">" + WIRE_U32.code)
# the layouts of the bodies read by hand, from the protocol's declarations
#: position2d DATA_STATE: pos (px, py, pa), vel (px, py, pa), stall
_POS_STATE = wire_layout(am.Position2dData)
#: laser DATA_SCAN up to the ranges: min_angle, max_angle, resolution, max_range, count x2
_LASER_HEAD = wire_layout(sm.LaserData, upto="ranges")
_POS_DATA_STATE = c.PLAYER_POSITION2D_DATA_STATE
_SONAR_DATA_RANGES = c.PLAYER_SONAR_DATA_RANGES
_LASER_DATA_SCAN = c.PLAYER_LASER_DATA_SCAN
_NOTHING: tuple[Any, Any] = (None, None)


class _FloatArrays:
    """``count`` big-endian f32 values at an offset, with the last size's struct kept."""

    __slots__ = ("_struct",)

    def __init__(self) -> None:
        self._struct = struct.Struct(">0f")

    def read(self, buf: Any, offset: int, count: int) -> tuple[float, ...]:
        st = self._struct
        if st.size != 4 * count:
            st = self._struct = struct.Struct(f">{count}f")
        return st.unpack_from(buf, offset)
#: header + position2d CMD VEL body (pose2d velocity, motor state) in one struct
_CMD_VEL = struct.Struct(HEADER_STRUCT.format + wire_layout(am.Position2dCmdVel).format[1:])
_CMD_VEL_SIZE = _CMD_VEL.size - HEADER_STRUCT.size


class ScanBody:
    """One laser scan as received; its ranges are decoded when first asked for.

    Immutable once made (the raw ranges are a copy), so it may be kept and read later, from
    any thread: ``values()`` is ``(min_angle, max_angle, resolution, max_range, ranges,
    intensity, id)``, the fields of ``LaserData`` in order.
    """

    __slots__ = ("_floats", "_head", "_raw", "_values", "count")

    def __init__(self, head: tuple[Any, ...], count: int, raw: bytes,
                 floats: _FloatArrays | None = None,
                 values: tuple[Any, ...] | None = None) -> None:
        self._head = head  # (min_angle, max_angle, resolution, max_range, intensity, id)
        self.count = count
        self._raw = raw
        self._floats = floats
        self._values = values

    def values(self) -> tuple[float, float, float, float, tuple[float, ...], bytes, int]:
        v = self._values
        if v is None:
            h = self._head
            assert self._floats is not None
            v = self._values = (h[0], h[1], h[2], h[3], self._floats.read(self._raw, 0, self.count),
                                h[4], h[5])
        return v


class Position2dProxy(Proxy):
    """A mobile base: odometric pose and velocity; velocity/position commands."""

    interf = int(Interface.POSITION2D)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self._values: tuple[float, float, float, float, float, float, int] | None = None
        self._state: tuple[Any, am.Position2dData | None] = _NOTHING
        self.geom: am.Position2dGeom | None = None

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _POS_DATA_STATE and end - start == _POS_STATE.size:
            self._values = _POS_STATE.unpack_from(buf, start)
            self.data_time_s = timestamp
            self.data_count += 1
            return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_POSITION2D_DATA_STATE:
            pos, vel = body.pos, body.vel
            values = (pos.px, pos.py, pos.pa, vel.px, vel.py, vel.pa, body.stall)
            self._state = (values, body)
            self._values = values
        elif subtype == c.PLAYER_POSITION2D_DATA_GEOM:
            self.geom = body

    @property
    def state_values(self) -> tuple[float, float, float, float, float, float, int] | None:
        """The latest state as ``(px, py, pa, vx, vy, vyaw, stall)`` (None before any)."""
        return self._values

    @property
    def state(self) -> am.Position2dData | None:
        values = self._values
        built = self._state
        if built[0] is values:
            return built[1]
        assert values is not None
        state = am.Position2dData(Pose2d(values[0], values[1], values[2]),
                                  Pose2d(values[3], values[4], values[5]), values[6])
        self._state = (values, state)
        return state

    @property
    def x(self) -> float:
        return self._values[0] if self._values else 0.0

    @property
    def y(self) -> float:
        return self._values[1] if self._values else 0.0

    @property
    def yaw(self) -> float:
        return self._values[2] if self._values else 0.0

    @property
    def vx(self) -> float:
        return self._values[3] if self._values else 0.0

    @property
    def vy(self) -> float:
        return self._values[4] if self._values else 0.0

    @property
    def vyaw(self) -> float:
        return self._values[5] if self._values else 0.0

    @property
    def stall(self) -> bool:
        return bool(self._values[6]) if self._values else False

    def set_velocity(self, vx_mps: float, vyaw_radps: float, vy_mps: float = 0.0,
                     enable: bool = True, *, defer: bool = False) -> None:
        """Command a velocity; ``defer=True`` sends it with the client's next message
        (see ``PlayerClient.send_encoded``)."""
        # sent every tick by a controller: header and body packed in one go (the same
        # bytes as encoding Position2dCmdVel(Pose2d(vx, vy, vyaw), enable))
        client = self.client
        try:
            wire = _CMD_VEL.pack(0, 0, self.interf, self.index, _CMD, c.PLAYER_POSITION2D_CMD_VEL,
                                 client.clock(), 0, _CMD_VEL_SIZE, vx_mps, vy_mps, vyaw_radps,
                                 int(enable))
        except struct.error as exc:
            raise EncodeError(f"Position2dCmdVel: cannot encode ({vx_mps!r}, {vy_mps!r}, "
                              f"{vyaw_radps!r}, {enable!r}): {exc}") from exc
        client.send_encoded(wire, defer=defer)

    def stop(self) -> None:
        self.set_velocity(0.0, 0.0)

    def goto(self, x: float, y: float, yaw_rad: float, vx_mps: float = 0.0,
             vyaw_radps: float = 0.0) -> None:
        self.command(c.PLAYER_POSITION2D_CMD_POS, am.Position2dCmdPos(
            Pose2d(x, y, yaw_rad), Pose2d(vx_mps, 0.0, vyaw_radps), 1))

    def set_car(self, velocity_mps: float, steering_rad: float) -> None:
        self.command(c.PLAYER_POSITION2D_CMD_CAR, am.Position2dCmdCar(velocity_mps, steering_rad))

    def set_vel_head(self, velocity_mps: float, heading_rad: float) -> None:
        self.command(c.PLAYER_POSITION2D_CMD_VEL_HEAD,
                     am.Position2dCmdVelHead(velocity_mps, heading_rad))

    def get_geometry(self, timeout_s: float | None = None) -> am.Position2dGeom:
        self.geom = self.request(c.PLAYER_POSITION2D_REQ_GET_GEOM, None, timeout_s)
        return self.geom

    def set_motor_power(self, on: bool) -> None:
        self.request(c.PLAYER_POSITION2D_REQ_MOTOR_POWER, am.Position2dPowerConfig(int(on)))

    def set_odometry(self, x: float, y: float, yaw_rad: float) -> None:
        self.request(c.PLAYER_POSITION2D_REQ_SET_ODOM,
                     am.Position2dSetOdomReq(Pose2d(x, y, yaw_rad)))

    def reset_odometry(self) -> None:
        self.request(c.PLAYER_POSITION2D_REQ_RESET_ODOM)


class SonarProxy(Proxy):
    interf = int(Interface.SONAR)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.ranges: tuple[float, ...] = ()
        self.poses: tuple[Pose3d, ...] = ()
        self._floats = _FloatArrays()

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _SONAR_DATA_RANGES and end - start >= 8:
            n, n2 = _COUNTS.unpack_from(buf, start)
            if n == n2 and end - start == 8 + 4 * n:
                self.ranges = self._floats.read(buf, start + 8, n)
                self.data_time_s = timestamp
                self.data_count += 1
                return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_SONAR_DATA_RANGES:
            self.ranges = body.ranges
        elif subtype == c.PLAYER_SONAR_DATA_GEOM:
            self.poses = body.poses

    def get_geometry(self, timeout_s: float | None = None) -> tuple[Pose3d, ...]:
        self.poses = self.request(c.PLAYER_SONAR_REQ_GET_GEOM, None, timeout_s).poses
        return self.poses


class LaserProxy(Proxy):
    interf = int(Interface.LASER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self._body: ScanBody | None = None
        self._scan: tuple[Any, sm.LaserData | None] = _NOTHING
        self.geom: sm.LaserGeom | None = None
        self.config: sm.LaserConfig | None = None
        self._floats = _FloatArrays()

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _LASER_DATA_SCAN and end - start >= 36:
            min_angle, max_angle, resolution, max_range, n, n2 = _LASER_HEAD.unpack_from(
                buf, start)
            at = start + 24 + 4 * n
            if n == n2 and at + 12 <= end:
                m, m2 = _COUNTS.unpack_from(buf, at)
                if m == m2 and at + 12 + m + (-m & 3) == end:
                    self._body = ScanBody(
                        (min_angle, max_angle, resolution, max_range,
                         bytes(buf[at + 8:at + 8 + m]) if m else b"",
                         _U32.unpack_from(buf, end - 4)[0]),
                        n, bytes(buf[start + 24:at]), self._floats)
                    self.data_time_s = timestamp
                    self.data_count += 1
                    return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_LASER_DATA_SCANPOSE:
            body = body.scan
        elif subtype != c.PLAYER_LASER_DATA_SCAN:
            return
        values = (body.min_angle, body.max_angle, body.resolution, body.max_range, body.ranges,
                  body.intensity, body.id)
        self._scan = (values, body)
        self._body = ScanBody((), len(body.ranges), b"", None, values)

    @property
    def scan_body(self) -> ScanBody | None:
        """The latest scan, ranges not decoded yet (None before any)."""
        return self._body

    @property
    def _values(self) -> tuple[float, float, float, float, tuple[float, ...], bytes,
                               int] | None:
        body = self._body
        return None if body is None else body.values()

    @property
    def scan_values(self) -> tuple[float, float, float, float, tuple[float, ...], bytes,
                                   int] | None:
        """The latest scan as ``(min_angle, max_angle, resolution, max_range, ranges,
        intensity, id)`` (None before any)."""
        return self._values

    @property
    def scan(self) -> sm.LaserData | None:
        values = self._values
        built = self._scan
        if built[0] is values:
            return built[1]
        assert values is not None
        scan = sm.LaserData(*values)
        self._scan = (values, scan)
        return scan

    @property
    def ranges(self) -> tuple[float, ...]:
        return self._values[4] if self._values else ()

    @property
    def intensity(self) -> bytes:
        return self._values[5] if self._values else b""

    @property
    def scan_id(self) -> int:
        return self._values[6] if self._values else 0

    @property
    def min_angle(self) -> float:
        return self._values[0] if self._values else 0.0

    @property
    def resolution(self) -> float:
        return self._values[2] if self._values else 0.0

    @property
    def max_range(self) -> float:
        return self._values[3] if self._values else 0.0

    def bearings(self) -> tuple[float, ...]:
        v = self._values
        return tuple(v[0] + i * v[2] for i in range(len(v[4]))) if v else ()

    def points(self) -> tuple[tuple[float, float], ...]:
        """Scan points in the laser frame."""
        return tuple((r * math.cos(b), r * math.sin(b))
                     for r, b in zip(self.ranges, self.bearings(), strict=True))

    def get_geometry(self, timeout_s: float | None = None) -> sm.LaserGeom:
        self.geom = self.request(c.PLAYER_LASER_REQ_GET_GEOM, None, timeout_s)
        return self.geom

    def get_config(self, timeout_s: float | None = None) -> sm.LaserConfig:
        self.config = self.request(c.PLAYER_LASER_REQ_GET_CONFIG, None, timeout_s)
        return self.config

    def set_config(self, config: sm.LaserConfig) -> sm.LaserConfig:
        reply = self.request(c.PLAYER_LASER_REQ_SET_CONFIG, config)
        self.config = reply if reply is not None else config
        return self.config


class RangerProxy(Proxy):
    interf = int(Interface.RANGER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.ranges: tuple[float, ...] = ()
        self.intensities: tuple[float, ...] = ()
        self.geom: sm.RangerGeom | None = None
        self.config: sm.RangerConfig | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_RANGER_DATA_RANGE:
            self.ranges = body.ranges
        elif subtype == c.PLAYER_RANGER_DATA_RANGESTAMPED:
            self.ranges = body.data.ranges
            if body.have_geom:
                self.geom = body.geom
            if body.have_config:
                self.config = body.config
        elif subtype == c.PLAYER_RANGER_DATA_INTNS:
            self.intensities = body.intensities
        elif subtype == c.PLAYER_RANGER_DATA_GEOM:
            self.geom = body

    def bearings(self) -> tuple[float, ...]:
        cfg = self.config
        if cfg is None:
            return ()
        return tuple(cfg.min_angle + i * cfg.angular_res for i in range(len(self.ranges)))

    def get_geometry(self, timeout_s: float | None = None) -> sm.RangerGeom:
        self.geom = self.request(c.PLAYER_RANGER_REQ_GET_GEOM, None, timeout_s)
        return self.geom

    def get_config(self, timeout_s: float | None = None) -> sm.RangerConfig:
        self.config = self.request(c.PLAYER_RANGER_REQ_GET_CONFIG, None, timeout_s)
        return self.config

    def set_config(self, config: sm.RangerConfig) -> sm.RangerConfig:
        self.config = self.request(c.PLAYER_RANGER_REQ_SET_CONFIG, config)
        return self.config


PROXIES: dict[str, type[Proxy]] = {
    "position2d": Position2dProxy,
    "sonar": SonarProxy,
    "laser": LaserProxy,
    "ranger": RangerProxy,
    "blobfinder": BlobfinderProxy,
    "camera": CameraProxy,
    "gripper": GripperProxy,
    "bumper": BumperProxy,
    "power": PowerProxy,
    "ptz": PtzProxy,
    "fiducial": FiducialProxy,
    "imu": ImuProxy,
    "simulation": SimulationProxy,
    "opaque": OpaqueProxy,
}
