"""The world's overhead camera: what it tracks, as blobs (pixels) and fiducials (metres).

Served on its own port as the devices of a non-mobile "robot". Blob centroids are pixel
coordinates of the downward view (x to the right = world +x, y downward = world -y);
fiducial poses are world-frame offsets from the point below the camera, with the id the
world gives the thing (-1 if none) and the thing's yaw.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from player_server.drivers.base import Driver, Reply, Unsupported, ack
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox2d, Bbox3d, Pose3d
from player_server.protocol.constants import Interface

_BLOB_HALF_PX = 2


def fiducial_ids(world: Any) -> dict[str, int]:
    """Name -> fiducial id of every robot and object that has one (> 0)."""
    ids: dict[str, int] = {}
    for r in world.robots:
        if r.fiducial_id > 0:
            ids[r.name] = int(r.fiducial_id)
    for o in world.objects:
        if o.fiducial_id > 0:
            ids[o.name] = int(o.fiducial_id)
    return ids


class OverheadBlobfinderDriver(Driver):
    interf = int(Interface.BLOBFINDER)

    def __init__(self, sim: Any, world: Any, index: int = 0) -> None:
        super().__init__(index, "sim_overhead_blobfinder")
        self.sim = sim
        self.cam = world.overhead_camera

    def to_pixels(self, x: float, y: float) -> tuple[int, int] | None:
        cam = self.cam
        u = (x - cam.x) / cam.view_size_x_m * cam.width_px + cam.width_px / 2.0
        v = cam.height_px / 2.0 - (y - cam.y) / cam.view_size_y_m * cam.height_px
        if 0 <= u < cam.width_px and 0 <= v < cam.height_px:
            return int(u), int(v)
        return None

    def data(self) -> Sequence[tuple[int, Any]]:
        blobs = []
        h = _BLOB_HALF_PX
        for i, t in enumerate(self.sim.overhead()):
            px = self.to_pixels(t.x, t.y)
            if px is None:
                continue
            u, v = px
            blobs.append(sm.BlobfinderBlob(i, t.colour & 0xFFFFFF, (2 * h + 1) ** 2, u, v,
                                           max(u - h, 0), u + h, max(v - h, 0), v + h,
                                           float(self.cam.height_m)))
        return ((c.PLAYER_BLOBFINDER_DATA_BLOBS, sm.BlobfinderData(
            self.cam.width_px, self.cam.height_px, tuple(blobs))),)


class OverheadFiducialDriver(Driver):
    interf = int(Interface.FIDUCIAL)
    requests = frozenset({c.PLAYER_FIDUCIAL_REQ_GET_GEOM, c.PLAYER_FIDUCIAL_REQ_GET_FOV})

    def __init__(self, sim: Any, world: Any, index: int = 0) -> None:
        super().__init__(index, "sim_overhead_fiducial")
        self.sim = sim
        self.cam = world.overhead_camera
        self.ids = fiducial_ids(world)

    def data(self) -> Sequence[tuple[int, Any]]:
        cam = self.cam
        items = tuple(
            sm.FiducialItem(self.ids.get(t.name, -1),
                            Pose3d(t.x - cam.x, t.y - cam.y, -cam.height_m, 0.0, 0.0, t.yaw),
                            Pose3d())
            for t in self.sim.overhead()
            if abs(t.x - cam.x) <= cam.view_size_x_m / 2
            and abs(t.y - cam.y) <= cam.view_size_y_m / 2
        )
        return ((c.PLAYER_FIDUCIAL_DATA_SCAN, sm.FiducialData(items)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        cam = self.cam
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_GEOM:
            return ack(sm.FiducialGeom(Pose3d(cam.x, cam.y, cam.height_m, 0.0, 1.5707963267948966,
                                              0.0), Bbox3d(0.1, 0.1, 0.1), Bbox2d(0.1, 0.1)))
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_FOV:
            return ack(sm.FiducialFov(0.0, float(cam.height_m) * 2.0,
                                      float(max(cam.view_size_x_m, cam.view_size_y_m))))
        raise Unsupported(f"fiducial request {subtype}")
