"""The world's overhead camera: what it tracks, as blobs (pixels) and fiducials (metres).

Served on its own port as the devices of a non-mobile "robot". Blob centroids are pixel
coordinates of the downward view (x to the right = world +x, y downward = world -y);
fiducial poses are world-frame offsets from the point below the camera, with the id the
world gives the thing (-1 if none) and the thing's yaw. The camera device draws the same
view as an RGB image: the floor, and each tracked thing as a disc of its colour and size.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from player_server.drivers.base import Driver, Reply, Unsupported, ack, declared
from player_server.drivers.vision import ImageDriver
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import POSE3D_ZERO, Bbox2d, Bbox3d, Pose3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import OverheadPort
    from worlds import WorldSpec


# bodies built every tick: the positional constructors fill the slots directly
_MAKE_BLOB = sm.BlobfinderBlob.xdr_make  # type: ignore[attr-defined]
_MAKE_BLOBS = sm.BlobfinderData.xdr_make  # type: ignore[attr-defined]
_MAKE_ITEM = sm.FiducialItem.xdr_make  # type: ignore[attr-defined]
_MAKE_FIDUCIALS = sm.FiducialData.xdr_make  # type: ignore[attr-defined]
_MAKE_POSE = Pose3d.xdr_make  # type: ignore[attr-defined]


def fiducial_ids(world: WorldSpec) -> dict[str, int]:
    """Name -> fiducial id of every robot and object that has one (> 0)."""
    ids: dict[str, int] = {}
    for r in world.robots:
        if r.fiducial_id > 0:
            ids[r.name] = int(r.fiducial_id)
    for o in world.objects:
        if o.fiducial_id > 0:
            ids[o.name] = int(o.fiducial_id)
    return ids


def footprint_radii(world: WorldSpec) -> dict[str, float]:
    """Name -> radius (m) of the disc drawn for each thing the overhead camera tracks."""
    radii: dict[str, float] = {}
    for r in world.robots:
        radii[r.name] = max(r.body.width_m, r.body.length_m) / 2.0
    for b in world.boxes:
        radii[b.name] = max(b.size_x_m, b.size_y_m) / 2.0
    for o in world.objects:
        radii[o.name] = o.radius_m
    for m in world.markers:
        radii[m.name] = m.radius_m
    return radii


class OverheadBlobfinderDriver(Driver):
    """One blob per tracked thing in view: centroid, box and area of its drawn disc."""

    interf = int(Interface.BLOBFINDER)

    def __init__(self, sim: OverheadPort, world: WorldSpec, index: int = 0) -> None:
        super().__init__(index, "sim_overhead_blobfinder")
        self.sim = sim
        self.cam = declared(world.overhead_camera, "the world", "overhead camera")
        self.radii = footprint_radii(world)
        self._discs: dict[str, tuple[float, float, int]] = {}
        # name -> (x, y, index, blob or None when out of view) of the last data made
        self._known: dict[str, tuple[float, float, int, Any]] = {}

    def to_pixels(self, x: float, y: float) -> tuple[float, float]:
        cam = self.cam
        u = (x - cam.x) / cam.view_size_x_m * cam.width_px + cam.width_px / 2.0
        v = cam.height_px / 2.0 - (y - cam.y) / cam.view_size_y_m * cam.height_px
        return u, v

    def _disc(self, name: str) -> tuple[float, float, int]:
        """(half width, half height, area) in pixels of the disc drawn for a thing."""
        hit = self._discs.get(name)
        if hit is None:
            cam = self.cam
            r_m = self.radii.get(name, 0.1)
            ru = max(r_m / cam.view_size_x_m * cam.width_px, 0.5)
            rv = max(r_m / cam.view_size_y_m * cam.height_px, 0.5)
            hit = self._discs[name] = (ru, rv, max(int(math.pi * ru * rv), 1))
        return hit

    def data(self) -> Sequence[tuple[int, Any]]:
        cam = self.cam
        width, height = cam.width_px, cam.height_px
        known = self._known
        blobs = []
        for i, t in enumerate(self.sim.overhead()):
            x, y = t.x, t.y
            hit = known.get(t.name)
            # most things stand still: their blob is the one made last time
            if hit is not None and hit[0] == x and hit[1] == y and hit[2] == i:
                if hit[3] is not None:
                    blobs.append(hit[3])
                continue
            u, v = self.to_pixels(x, y)
            blob = None
            if 0 <= u < width and 0 <= v < height:
                ru, rv, area = self._disc(t.name)
                left, right = int(u - ru), int(u + ru)
                top, bottom = int(v - rv), int(v + rv)
                blob = _MAKE_BLOB(
                    i, t.colour & 0xFFFFFF, area, int(u), int(v),
                    left if left > 0 else 0, right if right < width else width - 1,
                    top if top > 0 else 0, bottom if bottom < height else height - 1,
                    float(cam.height_m))
                blobs.append(blob)
            known[t.name] = (x, y, i, blob)
        return ((c.PLAYER_BLOBFINDER_DATA_BLOBS, _MAKE_BLOBS(width, height, tuple(blobs))),)


class OverheadFiducialDriver(Driver):
    interf = int(Interface.FIDUCIAL)
    requests = frozenset({c.PLAYER_FIDUCIAL_REQ_GET_GEOM, c.PLAYER_FIDUCIAL_REQ_GET_FOV})

    def __init__(self, sim: OverheadPort, world: WorldSpec, index: int = 0) -> None:
        super().__init__(index, "sim_overhead_fiducial")
        self.sim = sim
        self.cam = declared(world.overhead_camera, "the world", "overhead camera")
        self.ids = fiducial_ids(world)
        # name -> (x, y, yaw, item or None when out of view) of the last data made
        self._known: dict[str, tuple[float, float, float, Any]] = {}

    def data(self) -> Sequence[tuple[int, Any]]:
        cam = self.cam
        cx, cy, z = cam.x, cam.y, -cam.height_m
        half_x, half_y = cam.view_size_x_m / 2, cam.view_size_y_m / 2
        ids = self.ids
        known = self._known
        items = []
        for t in self.sim.overhead():
            x, y, yaw = t.x, t.y, t.yaw
            hit = known.get(t.name)
            # most things stand still: their item is the one made last time
            if hit is not None and hit[0] == x and hit[1] == y and hit[2] == yaw:
                item = hit[3]
            else:
                item = None
                if abs(x - cx) <= half_x and abs(y - cy) <= half_y:
                    item = _MAKE_ITEM(ids.get(t.name, -1),
                                      _MAKE_POSE(x - cx, y - cy, z, 0.0, 0.0, yaw), POSE3D_ZERO)
                known[t.name] = (x, y, yaw, item)
            if item is not None:
                items.append(item)
        return ((c.PLAYER_FIDUCIAL_DATA_SCAN, _MAKE_FIDUCIALS(tuple(items))),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        cam = self.cam
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_GEOM:
            return ack(sm.FiducialGeom(Pose3d(cam.x, cam.y, cam.height_m, 0.0, 1.5707963267948966,
                                              0.0), Bbox3d(0.1, 0.1, 0.1), Bbox2d(0.1, 0.1)))
        if subtype == c.PLAYER_FIDUCIAL_REQ_GET_FOV:
            return ack(sm.FiducialFov(0.0, float(cam.height_m) * 2.0,
                                      float(max(cam.view_size_x_m, cam.view_size_y_m))))
        raise Unsupported(f"fiducial request {subtype}")


class OverheadCameraDriver(ImageDriver):
    """A synthetic top-down RGB888 image (raw; the bool property ``jpeg`` compresses)."""

    requests = frozenset({c.PLAYER_CAMERA_REQ_GET_IMAGE})
    device_name = "overhead camera"

    def __init__(self, sim: OverheadPort, world: WorldSpec, index: int = 0) -> None:
        super().__init__(index, "sim_overhead_camera")
        self.sim = sim
        cam = declared(world.overhead_camera, "the world", "overhead camera")
        self.cam = cam
        self.radii = footprint_radii(world)
        floor = int(world.arena.floor_colour)
        self.floor_rgb = np.array([(floor >> 16) & 255, (floor >> 8) & 255, floor & 255],
                                  dtype=np.uint8)
        self.m_per_px_x = cam.view_size_x_m / cam.width_px
        self.m_per_px_y = cam.view_size_y_m / cam.height_px

    def render(self) -> Any:
        cam = self.cam
        img = np.empty((cam.height_px, cam.width_px, 3), dtype=np.uint8)
        img[:, :] = self.floor_rgb
        for t in self.sim.overhead():
            r_m = self.radii.get(t.name, 0.1)
            u = (t.x - cam.x) / self.m_per_px_x + cam.width_px / 2.0
            v = cam.height_px / 2.0 - (t.y - cam.y) / self.m_per_px_y
            ru, rv = r_m / self.m_per_px_x, r_m / self.m_per_px_y
            u0, u1 = max(int(u - ru), 0), min(int(u + ru) + 1, cam.width_px)
            v0, v1 = max(int(v - rv), 0), min(int(v + rv) + 1, cam.height_px)
            if u0 >= u1 or v0 >= v1:
                continue
            uu, vv = np.meshgrid(np.arange(u0, u1) + 0.5, np.arange(v0, v1) + 0.5)
            inside = ((uu - u) / max(ru, 1e-9)) ** 2 + ((vv - v) / max(rv, 1e-9)) ** 2 <= 1.0
            colour = int(t.colour)
            img[v0:v1, u0:u1][inside] = ((colour >> 16) & 255, (colour >> 8) & 255,
                                         colour & 255)
        return img
