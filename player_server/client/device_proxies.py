"""Proxies of the devices beyond the drive and the range sensors: blobfinder, camera,
gripper, bumper, power, PTZ, fiducial detector, inertial measurement unit, simulation and
opaque.

Each keeps its latest DATA body and typed accessors over it (see `proxies`); the blobfinder's
blobs and the power state are taken from the receive buffer in one piece, with layouts from
the protocol's declarations.
"""

from __future__ import annotations

import math
from typing import Any

from player_server.client.proxy import Proxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import imu_msgs as im
from player_server.protocol import sensor_msgs as sm
from player_server.protocol import simulation_msgs as simm
from player_server.protocol.common import Pose2d, Pose3d
from player_server.protocol.constants import Interface
from player_server.protocol.xdr import COUNT_WORDS, wire_layout

_COUNTS = COUNT_WORDS
_NOTHING: tuple[Any, Any] = (None, None)
#: blobfinder DATA_BLOBS up to the blobs: width, height, count x2
_BLOBS_HEAD = wire_layout(sm.BlobfinderData, upto="blobs")
#: one blob: id, color, area, x, y, left, right, top, bottom, range
_BLOB = wire_layout(sm.BlobfinderBlob)
#: power DATA_STATE: valid, volts, percent, joules, watts, charging
_POWER_STATE = wire_layout(am.PowerData)
_BLOBFINDER_DATA_BLOBS = c.PLAYER_BLOBFINDER_DATA_BLOBS
_POWER_DATA_STATE = c.PLAYER_POWER_DATA_STATE
_BUMPER_DATA_STATE = c.PLAYER_BUMPER_DATA_STATE


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


class ImuProxy(Proxy):
    """An inertial measurement unit: ``state`` is the latest DATA body, of whichever of the
    five layouts the device sends (``datatype``, its subtype); ``yaw``, ``gyro`` and ``accel``
    read the ones it carries (None when it does not)."""

    interf = int(Interface.IMU)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.datatype = 0
        self.state: Any = None

    def _update(self, subtype: int, body: Any) -> None:
        self.datatype, self.state = subtype, body

    @property
    def yaw(self) -> float | None:
        """The heading (rad), from any layout but CALIB."""
        d = self.state
        if isinstance(d, im.ImuDataState | im.ImuDataFullstate):
            return float(d.pose.pyaw)
        if isinstance(d, im.ImuDataEuler):
            return float(d.orientation.pyaw)
        if isinstance(d, im.ImuDataQuat):
            return 2.0 * math.atan2(d.q3, d.q0)
        return None

    @property
    def calib(self) -> im.ImuDataCalib | None:
        """Accelerations, turn rates and magnetic field, from CALIB, QUAT or EULER."""
        d = self.state
        if isinstance(d, im.ImuDataCalib):
            return d
        if isinstance(d, im.ImuDataQuat | im.ImuDataEuler):
            return d.calib_data
        return None

    @property
    def gyro(self) -> tuple[float, float, float] | None:
        """Turn rates about x, y, z (rad/s), from every layout but STATE."""
        cal = self.calib
        if cal is not None:
            return (cal.gyro_x, cal.gyro_y, cal.gyro_z)
        if isinstance(self.state, im.ImuDataFullstate):
            v = self.state.vel
            return (v.proll, v.ppitch, v.pyaw)
        return None

    @property
    def accel(self) -> tuple[float, float, float] | None:
        """Accelerations along x, y, z (m/s^2), from every layout but STATE."""
        cal = self.calib
        if cal is not None:
            return (cal.accel_x, cal.accel_y, cal.accel_z)
        if isinstance(self.state, im.ImuDataFullstate):
            a = self.state.acc
            return (a.px, a.py, a.pz)
        return None

    def set_datatype(self, datatype: int, timeout_s: float | None = None) -> None:
        """Ask for DATA of subtype `datatype` (1 state, 2 calib, 3 quat, 4 Euler, 5 full)."""
        self.request(c.PLAYER_IMU_REQ_SET_DATATYPE, im.ImuDatatypeConfig(datatype), timeout_s)

    def reset_orientation(self, value: int = 0, timeout_s: float | None = None) -> None:
        """Make the heading read 0 from now on."""
        self.request(c.PLAYER_IMU_REQ_RESET_ORIENTATION,
                     im.ImuResetOrientationConfig(value), timeout_s)


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
