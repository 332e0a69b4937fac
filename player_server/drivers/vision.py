"""Seeing devices: camera, blobfinder, fiducial detector and the pan-tilt-zoom head."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack, declared
from player_server.drivers.geometry import mount_pose
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox2d, Bbox3d, Pose3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec


CAMERA_SIZE = Bbox3d(0.1, 0.1, 0.1)


def encode_image(image: Any, jpeg: bool, quality: int) -> sm.CameraData:
    """An (H, W, 3) uint8 RGB array as camera data, raw RGB888 or JPEG."""
    height, width = int(image.shape[0]), int(image.shape[1])
    if jpeg:
        import cv2  # only needed when JPEG is asked for

        ok, buf = cv2.imencode(".jpg", image[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            raise ValueError("JPEG encoding failed")
        return sm.CameraData(width, height, 24, c.PLAYER_CAMERA_FORMAT_RGB888, 0,
                             c.PLAYER_CAMERA_COMPRESS_JPEG, buf.tobytes())
    return sm.CameraData(width, height, 24, c.PLAYER_CAMERA_FORMAT_RGB888, 0,
                         c.PLAYER_CAMERA_COMPRESS_RAW, image.tobytes())


class ImageDriver(Driver):
    """A camera serving what `render` draws as an RGB888 image: raw by default, JPEG when
    the bool property ``jpeg`` is set (quality from ``jpeg_quality``)."""

    interf = int(Interface.CAMERA)
    #: the device named in errors
    device_name = "camera"

    def __init__(self, index: int, driver_name: str) -> None:
        super().__init__(index, driver_name)
        self.properties = {"jpeg": False, "jpeg_quality": 80}
        self.property_limits = {"jpeg_quality": (1, 100)}

    def render(self) -> Any:
        """The current (H, W, 3) uint8 RGB image."""
        raise NotImplementedError

    def image(self) -> sm.CameraData:
        return encode_image(self.render(), bool(self.properties["jpeg"]),
                            int(self.properties["jpeg_quality"]))

    def data(self) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_CAMERA_DATA_STATE, self.image()),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_CAMERA_REQ_GET_IMAGE:
            return ack(self.image())
        raise Unsupported(f"{self.device_name} request {subtype}")


class CameraDriver(ImageDriver):
    """The robot's camera: images rendered by the simulator."""

    device = "camera"
    requests = frozenset({c.PLAYER_CAMERA_REQ_GET_SOURCE, c.PLAYER_CAMERA_REQ_GET_IMAGE})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_camera")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.camera, f"robot {robot.name!r}", "camera")

    def render(self) -> Any:
        return self.sim.camera_image(self.robot.name)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_CAMERA_REQ_GET_SOURCE:
            return ack(sm.CameraSourceReq("UNKNOWN", 0))
        return super().handle_request(subtype, body)


def _u32(value: float) -> int:
    return max(int(value), 0)


# bodies built every tick: the positional constructors fill the slots directly
_MAKE_BLOB = sm.BlobfinderBlob.xdr_make  # type: ignore[attr-defined]
_MAKE_BLOBS = sm.BlobfinderData.xdr_make  # type: ignore[attr-defined]
_MAKE_PTZ = am.PtzData.xdr_make  # type: ignore[attr-defined]


class BlobfinderDriver(Driver):
    device = "blobfinder"
    interf = int(Interface.BLOBFINDER)

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_blobfinder")
        self.sim = sim
        self.robot = robot
        cam = robot.devices.camera
        self.width = int(cam.width_px) if cam is not None else 0
        self.height = int(cam.height_px) if cam is not None else 0
        self._last: tuple[Any, Any] = (None, None)  # the simulator's blobs, the body made

    def data(self) -> Sequence[tuple[int, Any]]:
        seen = self.sim.blobs(self.robot.name)
        last_in, body = self._last
        if seen is last_in:  # the simulator hands back the same blobs while they are unchanged
            return ((c.PLAYER_BLOBFINDER_DATA_BLOBS, body),)
        # pixel quantities are whole non-negative numbers on the wire (u32), whatever
        # numeric type the simulator hands over
        blobs = tuple([
            _MAKE_BLOB(_u32(b.id), int(b.colour) & 0xFFFFFF, _u32(b.area), _u32(b.x),
                       _u32(b.y), _u32(b.l), _u32(b.r), _u32(b.t), _u32(b.b),
                       float(b.range_m))
            for b in seen
        ])
        body = _MAKE_BLOBS(self.width, self.height, blobs)
        self._last = (seen, body)
        return ((c.PLAYER_BLOBFINDER_DATA_BLOBS, body),)


class FiducialDriver(Driver):
    device = "fiducial"
    interf = int(Interface.FIDUCIAL)
    requests = frozenset({c.PLAYER_FIDUCIAL_REQ_GET_GEOM, c.PLAYER_FIDUCIAL_REQ_GET_FOV,
                          c.PLAYER_FIDUCIAL_REQ_GET_ID})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_fiducial")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.fiducial, f"robot {robot.name!r}", "fiducial")

    def data(self) -> Sequence[tuple[int, Any]]:
        items = tuple(
            sm.FiducialItem(int(f.id), Pose3d(f.x, f.y, 0.0, 0.0, 0.0, f.yaw), Pose3d())
            for f in self.sim.fiducials(self.robot.name)
        )
        return ((c.PLAYER_FIDUCIAL_DATA_SCAN, sm.FiducialData(items)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_GEOM:
            return ack(sm.FiducialGeom(mount_pose(self.spec.pose), CAMERA_SIZE,
                                       Bbox2d(0.1, 0.1)))
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_FOV:
            s = self.spec
            return ack(sm.FiducialFov(s.min_range_m, s.max_range_m, s.fov_rad))
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_ID:
            return ack(sm.FiducialId(int(self.robot.fiducial_id)))
        raise Unsupported(f"fiducial request {subtype}")


class PtzDriver(Driver):
    device = "ptz"
    interf = int(Interface.PTZ)
    commands = frozenset({c.PLAYER_PTZ_CMD_STATE})
    deferred_commands = commands  # pan/tilt/zoom targets, approached from the next step
    requests = frozenset({c.PLAYER_PTZ_REQ_CONTROL_MODE, c.PLAYER_PTZ_REQ_GEOM,
                          c.PLAYER_PTZ_REQ_STATUS})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_ptz")
        self.sim = sim
        self.robot = robot

    def data(self) -> Sequence[tuple[int, Any]]:
        p = self.sim.ptz(self.robot.name)
        return ((c.PLAYER_PTZ_DATA_STATE,
                 _MAKE_PTZ(p.pan, p.tilt, p.zoom, p.pan_speed, p.tilt_speed, 0)),)

    def handle_command(self, subtype: int, body: Any) -> None:
        if subtype != c.PLAYER_PTZ_CMD_STATE or body is None:
            raise Unsupported(f"ptz command {subtype}")
        zoom = body.zoom if body.zoom > 0 else self.sim.ptz(self.robot.name).zoom
        if not all(math.isfinite(v) for v in (body.pan, body.tilt, zoom)):
            raise ValueError("ptz targets must be finite")
        self.sim.ptz_command(self.robot.name, body.pan, body.tilt, zoom)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_PTZ_REQ_GEOM:
            cam = self.robot.devices.camera
            pose = mount_pose(cam.pose) if cam is not None else Pose3d()
            return ack(am.PtzGeom(pose, CAMERA_SIZE))
        if subtype == c.PLAYER_PTZ_REQ_STATUS:
            return ack(am.PtzReqStatus(0))
        if subtype == c.PLAYER_PTZ_REQ_CONTROL_MODE and body is not None and body.mode == 1:
            return ACK  # position control only
        raise Unsupported(f"ptz request {subtype}")
