"""Cameras and blobfinders, in both fidelities.

fast: the blobfinder's targets (robots, boxes, objects, markers, chargers) are projected into
the camera and checked for occlusion with one ray each, cast in the same batch as the range
sensors (`player_server.sim.sensing`); render: PyBullet renders the image and blobs are found
in it. A camera's image is always rendered. Blobs equal to the last ones of the same camera
are handed out as the same tuple.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pybullet as pb
from numpy.typing import NDArray

from player_server.sim import blobs as blobmod
from player_server.sim.devices.base import StatelessModel
from player_server.sim.fastsense import BlobPlan, BlobRow, Frame, make_blobs
from player_server.sim.read_schedule import ReadSchedule
from player_server.sim.readings import Blob

if TYPE_CHECKING:
    from player_server.sim.devices.world import DeviceWorld


class CameraModel(StatelessModel):
    kinds: ClassVar[tuple[str, ...]] = ("camera", "blobfinder")
    order: ClassVar[int] = 70

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world
        self.reads: ReadSchedule[int] = ReadSchedule()  # which a sensing pass looks for

    def build(self) -> None:
        self.plans: dict[tuple[int, ...], BlobPlan] = {}
        self._looks = 0  # the `Looks.version` the plans were made with
        self.last: dict[int, tuple[Blob, ...]] = {}
        self.last_rows: dict[int, tuple[BlobRow, ...]] = {}  # what each of `last` was made of

    def blobs(self, robot: str) -> tuple[Blob, ...]:
        w = self.world
        st = w.device(robot, "blobfinder")
        self.reads.note(st.index, w.tick)
        done = w.sensed_now()
        if done is not None and st.index in done["blobs"]:
            return done["blobs"][st.index]
        return w.sense()["blobs"][st.index]

    def camera_image(self, robot: str) -> NDArray[np.uint8]:
        w = self.world
        st = w.device(robot, "camera")

        def compute() -> NDArray[np.uint8]:
            img, _ = self.render_camera(self.cameras([st.index]).pose(0))
            img.setflags(write=False)
            return img

        return w.cached(("image", st.index), compute)  # type: ignore[return-value]

    def cameras(self, idx: list[int]) -> blobmod.Cameras:
        w = self.world
        frame = w.tick_arrays.frame()
        ii = np.array(idx, dtype=np.int64)
        ptz = [w.robots[i].ptz for i in idx]
        pan = np.array([p.pan if p is not None else 0.0 for p in ptz])
        tilt = np.array([p.tilt if p is not None else 0.0 for p in ptz])
        zoom = np.array([p.zoom if p is not None else 0.0 for p in ptz])
        return w.arrays.cameras(ii, frame.pos.real[ii], frame.pos.imag[ii], frame.yaw[ii],
                                 pan, tilt, zoom)

    # -- fast
    def fast_pending(self, cams: list[int], frame: Frame) -> tuple[BlobPlan, Any]:
        """The cameras' blob plan and its targets in view, waiting for their occlusion rays."""
        w = self.world
        cam_key = tuple(cams)
        if self._looks != w.looks.version:  # colours changed: plan anew
            self.plans.clear()
            self._looks = w.looks.version
        bplan = self.plans.get(cam_key)
        if bplan is None:
            bplan = self.plans[cam_key] = BlobPlan.build(cam_key, w.arrays)
        t_pos, t_head = w.tick_arrays.target_poses(frame)
        pan, _, zoom = w.ptz_arrays()
        return bplan, bplan.pending(frame, t_pos, t_head, pan, zoom, w.target_hidden)

    def fast_blobs(self, cams: list[int], bplan: BlobPlan, pending: Any,
                   visible: np.ndarray) -> dict[int, tuple[Blob, ...]]:
        """Each camera's blobs; a camera that sees exactly what it saw at the last tick gets
        the same tuple back (its Blobs are not made again, and readers can tell it by
        identity)."""
        pan, tilt, zoom = self.world.ptz_arrays()
        last_blobs = self.last
        last_rows = self.last_rows
        seen: dict[int, tuple[Blob, ...]] = {}
        for cam, rows in zip(cams, bplan.project(pending, visible, pan, tilt, zoom),
                             strict=True):
            blobs = last_blobs.get(cam)
            if blobs is None or last_rows.get(cam) != rows:
                blobs = last_blobs[cam] = make_blobs(rows)
                last_rows[cam] = rows
            seen[cam] = blobs
        return seen

    # -- render
    def render(self, cams: list[int]) -> dict[int, tuple[Blob, ...]]:
        camarr = self.cameras(cams)
        out: dict[int, tuple[Blob, ...]] = {}
        for j, i in enumerate(cams):
            bf = self.world.spec.robots[i].devices.blobfinder
            assert bf is not None
            pose = camarr.pose(j)
            rgb, depth = self.render_camera(pose)
            focal = (pose.width / 2) / math.tan(pose.fov_h / 2)
            out[i] = blobmod.detect(rgb, depth, bf.channels, bf.colour_tolerance,
                                    bf.min_area_px, focal)
        return out

    def render_camera(
        self, cam: blobmod.CameraPose
    ) -> tuple[NDArray[np.uint8], NDArray[np.float64]]:
        cid = self.world.physics_client
        near, far = 0.05, max(cam.max_range, 1.0)
        ct, st_ = math.cos(cam.tilt), math.sin(cam.tilt)
        eye = [cam.x, cam.y, cam.z]
        target = [cam.x + math.cos(cam.yaw) * ct, cam.y + math.sin(cam.yaw) * ct, cam.z + st_]
        view = pb.computeViewMatrix(eye, target, [0, 0, 1], physicsClientId=cid)
        aspect = cam.width / cam.height
        fov_v = math.degrees(2 * math.atan(math.tan(cam.fov_h / 2) / aspect))
        proj = pb.computeProjectionMatrixFOV(fov_v, aspect, near, far, physicsClientId=cid)
        _, _, px, dbuf, _ = pb.getCameraImage(
            cam.width, cam.height, view, proj, shadow=0, lightAmbientCoeff=1.0,
            lightDiffuseCoeff=0.0, lightSpecularCoeff=0.0, renderer=pb.ER_TINY_RENDERER,
            physicsClientId=cid,
        )
        rgba = np.asarray(px, dtype=np.uint8).reshape(cam.height, cam.width, 4)
        d = np.asarray(dbuf, dtype=np.float64).reshape(cam.height, cam.width)
        depth = far * near / (far - (far - near) * d)
        return np.ascontiguousarray(rgba[:, :, :3]), depth
