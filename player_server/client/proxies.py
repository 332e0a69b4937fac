"""Proxies for every interface the server offers.

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

from player_server.client.proxy import Proxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol import simulation_msgs as simm
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
#: blobfinder DATA_BLOBS up to the blobs: width, height, count x2
_BLOBS_HEAD = wire_layout(sm.BlobfinderData, upto="blobs")
#: one blob: id, color, area, x, y, left, right, top, bottom, range
_BLOB = wire_layout(sm.BlobfinderBlob)
#: power DATA_STATE: valid, volts, percent, joules, watts, charging
_POWER_STATE = wire_layout(am.PowerData)
_POS_DATA_STATE = c.PLAYER_POSITION2D_DATA_STATE
_SONAR_DATA_RANGES = c.PLAYER_SONAR_DATA_RANGES
_LASER_DATA_SCAN = c.PLAYER_LASER_DATA_SCAN
_BLOBFINDER_DATA_BLOBS = c.PLAYER_BLOBFINDER_DATA_BLOBS
_POWER_DATA_STATE = c.PLAYER_POWER_DATA_STATE
_BUMPER_DATA_STATE = c.PLAYER_BUMPER_DATA_STATE
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


class BlobfinderProxy(Proxy):
    interf = int(Interface.BLOBFINDER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self._values: tuple[int, int, tuple[tuple[Any, ...], ...]] | None = None
        self._state: tuple[Any, sm.BlobfinderData | None] = _NOTHING

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _BLOBFINDER_DATA_BLOBS and end - start >= 16:
            width, height, n, n2 = _BLOBS_HEAD.unpack_from(buf, start)
            if n == n2 and end - start == 16 + _BLOB.size * n:
                unpack = _BLOB.unpack_from
                self._values = (width, height, tuple([
                    unpack(buf, at) for at in range(start + 16, end, _BLOB.size)]))
                self.data_time_s = timestamp
                self.data_count += 1
                return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_BLOBFINDER_DATA_BLOBS:
            values = (body.width, body.height, tuple([
                (b.id, b.color, b.area, b.x, b.y, b.left, b.right, b.top, b.bottom, b.range)
                for b in body.blobs]))
            self._state = (values, body)
            self._values = values

    @property
    def blob_values(self) -> tuple[int, int, tuple[tuple[Any, ...], ...]] | None:
        """The latest blobs as ``(width, height, blobs)``, each blob ``(id, color, area, x,
        y, left, right, top, bottom, range)`` (None before any)."""
        return self._values

    @property
    def state(self) -> sm.BlobfinderData | None:
        values = self._values
        built = self._state
        if built[0] is values:
            return built[1]
        assert values is not None
        state = sm.BlobfinderData(values[0], values[1],
                                  tuple([sm.BlobfinderBlob(*b) for b in values[2]]))
        self._state = (values, state)
        return state

    @property
    def blobs(self) -> tuple[sm.BlobfinderBlob, ...]:
        state = self.state
        return state.blobs if state else ()

    @property
    def width(self) -> int:
        return self._values[0] if self._values else 0

    @property
    def height(self) -> int:
        return self._values[1] if self._values else 0


class CameraProxy(Proxy):
    """Images as sent: ``image`` is raw RGB888 rows, or a JPEG file when compressed."""

    interf = int(Interface.CAMERA)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.state: sm.CameraData | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_CAMERA_DATA_STATE:
            self.state = body

    @property
    def width(self) -> int:
        return self.state.width if self.state else 0

    @property
    def height(self) -> int:
        return self.state.height if self.state else 0

    @property
    def compressed(self) -> bool:
        return bool(self.state and self.state.compression == c.PLAYER_CAMERA_COMPRESS_JPEG)

    @property
    def image(self) -> bytes:
        return self.state.image if self.state else b""

    def get_image(self, timeout_s: float | None = None) -> sm.CameraData:
        self.state = self.request(c.PLAYER_CAMERA_REQ_GET_IMAGE, None, timeout_s)
        return self.state

    def set_compression(self, jpeg: bool) -> None:
        self.set_bool_prop("jpeg", jpeg)


class GripperProxy(Proxy):
    interf = int(Interface.GRIPPER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.state_data: am.GripperData | None = None
        self.geom: am.GripperGeom | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_GRIPPER_DATA_STATE:
            self.state_data = body

    @property
    def state(self) -> int:
        """OPEN 1, CLOSED 2, MOVING 3, ERROR 4 (0 before any data)."""
        return self.state_data.state if self.state_data else 0

    @property
    def beams(self) -> int:
        return self.state_data.beams if self.state_data else 0

    @property
    def stored(self) -> int:
        return self.state_data.stored if self.state_data else 0

    def open(self) -> None:
        self.command(c.PLAYER_GRIPPER_CMD_OPEN)

    def close(self) -> None:
        self.command(c.PLAYER_GRIPPER_CMD_CLOSE)

    def stop(self) -> None:
        self.command(c.PLAYER_GRIPPER_CMD_STOP)

    def store(self) -> None:
        self.command(c.PLAYER_GRIPPER_CMD_STORE)

    def retrieve(self) -> None:
        self.command(c.PLAYER_GRIPPER_CMD_RETRIEVE)

    def get_geometry(self, timeout_s: float | None = None) -> am.GripperGeom:
        self.geom = self.request(c.PLAYER_GRIPPER_REQ_GET_GEOM, None, timeout_s)
        return self.geom


class BumperProxy(Proxy):
    interf = int(Interface.BUMPER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.bumpers: tuple[bool, ...] = ()
        self.geom: sm.BumperGeom | None = None

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _BUMPER_DATA_STATE and end - start >= 8:
            n, n2 = _COUNTS.unpack_from(buf, start)
            if n == n2 and end - start == 8 + n + (-n & 3):
                self.bumpers = tuple([b != 0 for b in buf[start + 8:start + 8 + n]])
                self.data_time_s = timestamp
                self.data_count += 1
                return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_BUMPER_DATA_STATE:
            self.bumpers = tuple(b != 0 for b in body.bumpers)
        elif subtype == c.PLAYER_BUMPER_DATA_GEOM:
            self.geom = body

    @property
    def pressed(self) -> bool:
        return any(self.bumpers)

    def get_geometry(self, timeout_s: float | None = None) -> sm.BumperGeom:
        self.geom = self.request(c.PLAYER_BUMPER_REQ_GET_GEOM, None, timeout_s)
        return self.geom


class PowerProxy(Proxy):
    interf = int(Interface.POWER)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self._values: tuple[int, float, float, float, float, int] | None = None
        self._state: tuple[Any, am.PowerData | None] = _NOTHING

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        if subtype == _POWER_DATA_STATE and end - start == _POWER_STATE.size:
            self._values = _POWER_STATE.unpack_from(buf, start)
            self.data_time_s = timestamp
            self.data_count += 1
            return
        super()._on_raw(subtype, buf, start, end, timestamp)

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_POWER_DATA_STATE:
            values = (body.valid, body.volts, body.percent, body.joules, body.watts,
                      body.charging)
            self._state = (values, body)
            self._values = values

    @property
    def state_values(self) -> tuple[int, float, float, float, float, int] | None:
        """The latest state as ``(valid, volts, percent, joules, watts, charging)``."""
        return self._values

    @property
    def state(self) -> am.PowerData | None:
        values = self._values
        built = self._state
        if built[0] is values:
            return built[1]
        assert values is not None
        state = am.PowerData(*values)
        self._state = (values, state)
        return state

    @property
    def volts(self) -> float:
        return self._values[1] if self._values else 0.0

    @property
    def percent(self) -> float:
        return self._values[2] if self._values else 0.0

    @property
    def joules(self) -> float:
        return self._values[3] if self._values else 0.0

    @property
    def watts(self) -> float:
        return self._values[4] if self._values else 0.0

    @property
    def charging(self) -> int:
        """1 receiving charge, -1 supplying, 0 neither."""
        return self._values[5] if self._values else 0

    def set_charging_policy(self, enable_input: bool, enable_output: bool = True) -> None:
        self.request(c.PLAYER_POWER_REQ_SET_CHARGING_POLICY,
                     am.PowerChargePolicyConfig(int(enable_input), int(enable_output)))


class PtzProxy(Proxy):
    interf = int(Interface.PTZ)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.state: am.PtzData | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_PTZ_DATA_STATE:
            self.state = body

    @property
    def pan(self) -> float:
        return self.state.pan if self.state else 0.0

    @property
    def tilt(self) -> float:
        return self.state.tilt if self.state else 0.0

    @property
    def zoom(self) -> float:
        return self.state.zoom if self.state else 0.0

    def set_ptz(self, pan_rad: float, tilt_rad: float, zoom_rad: float,
                panspeed_radps: float = 0.0, tiltspeed_radps: float = 0.0) -> None:
        self.command(c.PLAYER_PTZ_CMD_STATE,
                     am.PtzCmd(pan_rad, tilt_rad, zoom_rad, panspeed_radps, tiltspeed_radps))

    def get_geometry(self, timeout_s: float | None = None) -> am.PtzGeom:
        return self.request(c.PLAYER_PTZ_REQ_GEOM, None, timeout_s)


class FiducialProxy(Proxy):
    interf = int(Interface.FIDUCIAL)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.fiducials: tuple[sm.FiducialItem, ...] = ()
        self.geom: sm.FiducialGeom | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_FIDUCIAL_DATA_SCAN:
            self.fiducials = body.fiducials

    def get_geometry(self, timeout_s: float | None = None) -> sm.FiducialGeom:
        self.geom = self.request(c.PLAYER_FIDUCIAL_REQ_GET_GEOM, None, timeout_s)
        return self.geom

    def get_fov(self) -> sm.FiducialFov:
        return self.request(c.PLAYER_FIDUCIAL_REQ_GET_FOV)

    def set_fov(self, fov: sm.FiducialFov) -> None:
        self.request(c.PLAYER_FIDUCIAL_REQ_SET_FOV, fov)

    def get_id(self) -> int:
        return int(self.request(c.PLAYER_FIDUCIAL_REQ_GET_ID, sm.FiducialId(0)).id)


class SimulationProxy(Proxy):
    """The world itself: ground-truth poses by name, pause, reset. It sends no data."""

    interf = int(Interface.SIMULATION)

    def get_pose2d(self, name: str, timeout_s: float | None = None) -> tuple[float, float, float]:
        r = self.request(c.PLAYER_SIMULATION_REQ_GET_POSE2D,
                         simm.SimulationPose2dReq(name, Pose2d()), timeout_s)
        return (r.pose.px, r.pose.py, r.pose.pa)

    def set_pose2d(self, name: str, x: float, y: float, yaw_rad: float) -> None:
        self.request(c.PLAYER_SIMULATION_REQ_SET_POSE2D,
                     simm.SimulationPose2dReq(name, Pose2d(x, y, yaw_rad)))

    def get_pose3d(self, name: str) -> tuple[Pose3d, float]:
        r = self.request(c.PLAYER_SIMULATION_REQ_GET_POSE3D,
                         simm.SimulationPose3dReq(name, Pose3d(), 0.0))
        return r.pose, r.simtime

    def set_pose3d(self, name: str, pose: Pose3d) -> None:
        self.request(c.PLAYER_SIMULATION_REQ_SET_POSE3D, simm.SimulationPose3dReq(name, pose, 0.0))

    def get_property(self, name: str, prop: str) -> bytes:
        r = self.request(c.PLAYER_SIMULATION_REQ_GET_PROPERTY,
                         simm.SimulationPropertyReq(name, prop, 0, b""))
        return bytes(r.value)

    def set_property(self, name: str, prop: str, value: bytes) -> None:
        self.request(c.PLAYER_SIMULATION_REQ_SET_PROPERTY,
                     simm.SimulationPropertyReq(name, prop, 0, value))

    def pause(self) -> None:
        """Toggle pause (Player's PAUSE command)."""
        self.command(c.PLAYER_SIMULATION_CMD_PAUSE)

    def reset(self) -> None:
        self.command(c.PLAYER_SIMULATION_CMD_RESET)

    def save(self) -> None:
        self.command(c.PLAYER_SIMULATION_CMD_SAVE)


class OpaqueProxy(Proxy):
    """Application-defined bytes (the team clock of a lockstep run, see
    `player_server.protocol.team_clock`): ``data`` is the latest DATA's bytes."""

    interf = int(Interface.OPAQUE)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.data: bytes = b""

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_OPAQUE_DATA_STATE:
            self.data = bytes(body.data)

    def send(self, data: bytes) -> None:
        """Send bytes as an opaque command (CMD 2, never answered)."""
        self.command(c.PLAYER_OPAQUE_CMD_DATA, sm.OpaqueData(bytes(data)))


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
    "simulation": SimulationProxy,
    "opaque": OpaqueProxy,
}
