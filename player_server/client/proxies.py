"""Proxies for every interface the server offers.

Each keeps its latest DATA body (``state``, ``scan``, ...) and typed accessors over it,
the geometry it last requested, and methods for the device's commands and requests.
Angles in radians, distances in metres, times in simulation seconds.
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

_CMD = int(MsgType.CMD)
#: header + position2d CMD VEL body (pose2d velocity, motor state) in one struct
_CMD_VEL = struct.Struct(HEADER_STRUCT.format + "dddI")
_CMD_VEL_SIZE = _CMD_VEL.size - HEADER_STRUCT.size


class Position2dProxy(Proxy):
    """A mobile base: odometric pose and velocity; velocity/position commands."""

    interf = int(Interface.POSITION2D)

    def __init__(self, client: Any, index: int = 0) -> None:
        super().__init__(client, index)
        self.state: am.Position2dData | None = None
        self.geom: am.Position2dGeom | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_POSITION2D_DATA_STATE:
            self.state = body
        elif subtype == c.PLAYER_POSITION2D_DATA_GEOM:
            self.geom = body

    @property
    def x(self) -> float:
        return self.state.pos.px if self.state else 0.0

    @property
    def y(self) -> float:
        return self.state.pos.py if self.state else 0.0

    @property
    def yaw(self) -> float:
        return self.state.pos.pa if self.state else 0.0

    @property
    def vx(self) -> float:
        return self.state.vel.px if self.state else 0.0

    @property
    def vy(self) -> float:
        return self.state.vel.py if self.state else 0.0

    @property
    def vyaw(self) -> float:
        return self.state.vel.pa if self.state else 0.0

    @property
    def stall(self) -> bool:
        return bool(self.state.stall) if self.state else False

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
        self.scan: sm.LaserData | None = None
        self.geom: sm.LaserGeom | None = None
        self.config: sm.LaserConfig | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_LASER_DATA_SCAN:
            self.scan = body
        elif subtype == c.PLAYER_LASER_DATA_SCANPOSE:
            self.scan = body.scan

    @property
    def ranges(self) -> tuple[float, ...]:
        return self.scan.ranges if self.scan else ()

    @property
    def intensity(self) -> bytes:
        return self.scan.intensity if self.scan else b""

    @property
    def scan_id(self) -> int:
        return self.scan.id if self.scan else 0

    @property
    def min_angle(self) -> float:
        return self.scan.min_angle if self.scan else 0.0

    @property
    def resolution(self) -> float:
        return self.scan.resolution if self.scan else 0.0

    @property
    def max_range(self) -> float:
        return self.scan.max_range if self.scan else 0.0

    def bearings(self) -> tuple[float, ...]:
        s = self.scan
        return tuple(s.min_angle + i * s.resolution for i in range(len(s.ranges))) if s else ()

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
        self.state: sm.BlobfinderData | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_BLOBFINDER_DATA_BLOBS:
            self.state = body

    @property
    def blobs(self) -> tuple[sm.BlobfinderBlob, ...]:
        return self.state.blobs if self.state else ()

    @property
    def width(self) -> int:
        return self.state.width if self.state else 0

    @property
    def height(self) -> int:
        return self.state.height if self.state else 0


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
        self.state: am.PowerData | None = None

    def _update(self, subtype: int, body: Any) -> None:
        if subtype == c.PLAYER_POWER_DATA_STATE:
            self.state = body

    @property
    def volts(self) -> float:
        return self.state.volts if self.state else 0.0

    @property
    def percent(self) -> float:
        return self.state.percent if self.state else 0.0

    @property
    def joules(self) -> float:
        return self.state.joules if self.state else 0.0

    @property
    def watts(self) -> float:
        return self.state.watts if self.state else 0.0

    @property
    def charging(self) -> int:
        """1 receiving charge, -1 supplying, 0 neither."""
        return self.state.charging if self.state else 0

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
}
