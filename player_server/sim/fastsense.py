"""Per-tick vectorised geometry for the fast sensors (pure numpy).

Planar poses are complex numbers: a position ``x + iy`` and a heading ``exp(i yaw)``, so a
robot-frame offset ``l`` lands at ``pos + head * l`` in one multiply-add for every ray or
camera at once. Plans (which rays, which camera/target pairs) are built once per set of active
sensors; each tick only evaluates them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from player_server.sim import grid_index
from player_server.sim.blob_kernel import DZ_BOTTOM, DZ_TOP, blob_boxes, pending_near
from player_server.sim.readings import Blob, fast_constructor
from player_server.sim.world_arrays import WorldArrays
from worlds import RobotSpec

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]
_make_blob = fast_constructor(Blob)


BlobRow = tuple[int, int, int, int, int, int, int, int, int, float]
"""A `Blob`'s fields in order: channel, colour, area, x, y, left, right, top, bottom, range."""


def make_blobs(rows: tuple[BlobRow, ...]) -> tuple[Blob, ...]:
    """The `Blob`s of one camera's rows."""
    make = _make_blob
    return tuple([make(*row) for row in rows])


@dataclass(frozen=True)
class Frame:
    """Robot poses at one tick: axle-centre position, heading, yaw, body-centre position
    (per robot)."""

    pos: C128
    head: C128
    yaw: F64
    body: C128


@dataclass(frozen=True)
class RangePlan:
    """The rays of a set of range sensors, concatenated, in their robots' frames."""

    keys: tuple[tuple[int, str], ...]
    robot: NDArray[np.int64]
    local: C128
    unit: C128
    z: F64
    min_range: F64
    max_range: F64
    counts: tuple[int, ...]
    groups: tuple[int, ...]  # rays per reading (sonar cones)
    own: NDArray[np.int64]  # footprint of the robot's body when the ray starts inside, or -1
    # The first ray of every reading (a ranger's rays each start one), the offset of each
    # sensor's first ray and of its first reading (one more of each at the end: the totals).
    reading_rays: NDArray[np.intp]
    ray_start: tuple[int, ...]
    reading_start: NDArray[np.intp]
    reading_start_list: tuple[int, ...]

    @staticmethod
    def build(keys: tuple[tuple[int, str], ...], robots: tuple[RobotSpec, ...],
              wa: WorldArrays, fans: Mapping[tuple[int, str], tuple[float, float, int]]
              | None = None) -> RangePlan:
        """``fans``: the rays of a laser or ranger cast at (first angle, spacing, count)
        instead of its world-file `samples` over its field of view."""
        parts = []
        for idx, kind in keys:
            d = getattr(robots[idx].devices, kind)
            if kind == "sonar":
                k = d.rays_per_transducer
                offs = np.zeros(1) if k == 1 else np.linspace(-d.cone_rad / 2, d.cone_rad / 2, k)
                local = np.repeat([complex(m.x, m.y) for m in d.poses], k)
                la = np.repeat([m.yaw for m in d.poses], k) + np.tile(offs, len(d.poses))
                z = d.poses[0].z
            else:
                k = 1
                fan = fans.get((idx, kind)) if fans else None
                angles = (d.angles_rad() if fan is None
                          else fan[0] + fan[1] * np.arange(fan[2], dtype=np.float64))
                la = np.array(angles) + d.pose.yaw
                local = np.full(la.size, complex(d.pose.x, d.pose.y))
                z = d.pose.z
            parts.append((idx, local, np.exp(1j * la), z, d.min_range_m, d.max_range_m, k))
        counts = tuple(p[1].size for p in parts)
        robot = np.repeat([p[0] for p in parts], counts).astype(np.int64)
        local = np.concatenate([p[1] for p in parts])
        ray_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)
        per_reading = [1 if kind == "ranger" else p[6] for (_, kind), p in zip(keys, parts,
                                                                              strict=True)]
        reading_rays = np.concatenate(
            [np.arange(a, b, g, dtype=np.intp)
             for a, b, g in zip(ray_start[:-1], ray_start[1:], per_reading, strict=True)]
            + [np.zeros(0, dtype=np.intp)])
        n_readings = [c // g for c, g in zip(counts, per_reading, strict=True)]
        reading_start = np.concatenate([[0], np.cumsum(n_readings)]).astype(np.intp)
        return RangePlan(
            keys=keys,
            robot=robot,
            local=local,
            unit=np.concatenate([p[2] for p in parts]),
            z=np.repeat([p[3] for p in parts], counts).astype(np.float64),
            min_range=np.repeat([p[4] for p in parts], counts).astype(np.float64),
            max_range=np.repeat([p[5] for p in parts], counts).astype(np.float64),
            counts=counts,
            groups=tuple(p[6] for p in parts),
            own=wa.own_body(robot, local),
            reading_rays=reading_rays,
            ray_start=tuple(ray_start.tolist()),
            reading_start=reading_start,
            reading_start_list=tuple(reading_start.tolist()),
        )

    def rays(self, frame: Frame) -> tuple[C128, C128]:
        """World origins and unit directions of every ray."""
        head = frame.head[self.robot]
        return frame.pos[self.robot] + head * self.local, head * self.unit

    def split(self, ranges: F64) -> dict[tuple[int, str], np.ndarray]:
        """Per-sensor readings (cone minima, clipped to each sensor's limits), read-only."""
        r, cones = self.minima(ranges)
        return {key: self.reading(i, r, cones) for i, key in enumerate(self.keys)}

    def minima(self, ranges: F64) -> tuple[F64, NDArray[np.float32]]:
        """The ranges clipped to each sensor's limits, and every reading of every sensor but
        the rangers (a sonar's, the minimum over its cone; float32) in one array."""
        r = np.minimum(np.maximum(ranges, self.min_range), self.max_range)
        if self.reading_rays.size == 0:
            return r, np.zeros(0, dtype=np.float32)
        cones = np.minimum.reduceat(r.astype(np.float32), self.reading_rays)
        return r, cones

    def reading(self, i: int, r: F64, cones: NDArray[np.float32]) -> np.ndarray:
        """Sensor i's reading (a read-only array of its own) from `minima`: a ranger's
        clipped ranges (float64), the others' readings (float32)."""
        part: np.ndarray
        if self.keys[i][1] == "ranger":
            part = r[self.ray_start[i]:self.ray_start[i + 1]].copy()
        else:
            part = cones[self.reading_start_list[i]:self.reading_start_list[i + 1]].copy()
        part.setflags(write=False)
        return part


@dataclass(frozen=True)
class Pending:
    """Camera/target pairs in range and in view, awaiting the occlusion test."""

    slot: NDArray[np.int64]  # the camera's slot in the plan
    target: NDArray[np.int64]
    channel: NDArray[np.int64]
    origin: C128  # camera position (occlusion ray origin)
    direction: C128  # unit vector to the target centre
    dist: F64
    near: F64
    bearing: F64  # relative to the camera axis, anticlockwise
    half: F64  # angular half-width
    rows: F64  # (4, pairs): dist, near, bearing, half


@dataclass(frozen=True)
class BlobPlan:
    """The blobfinders of a set of cameras, and every blob target of the world.

    A camera sees a target whose colour one of its channels tracks (the first such channel);
    each tick the targets near each camera are found in a grid of the targets
    (`blob_kernel.pending_near`), so the cost grows with cameras times the targets near
    each, not times all targets.
    """

    cams: tuple[int, ...]
    robot: NDArray[np.int64]  # per camera slot
    mount: C128
    mount_yaw: F64
    cam_z: F64
    fov: F64
    max_range: F64
    cam_channel: NDArray[np.int64]  # (slots, palette colours): channel or -1
    # Per camera for projecting: width/2, height/2, field of view, tilt, (dz_top, dz_bottom:
    # per target, filled in per pair), min_area, width - 1, height - 1.
    cam_consts: F64
    own: NDArray[np.int64]  # footprint of the robot's body when its camera is inside, or -1
    t_colour_index: NDArray[np.int64]
    t_colour: NDArray[np.int64]
    radius: F64
    half_x: F64
    half_y: F64
    z_top: F64
    z_bottom: F64
    reach: F64  # per target: its furthest point from its centre
    bound: float
    few: grid_index.Grid  # every target in one cell (for worlds with few targets)

    @staticmethod
    def build(cams: tuple[int, ...], wa: WorldArrays) -> BlobPlan:
        robot = np.array(cams, dtype=np.int64)
        cam = wa.cam[robot] if cams else np.zeros((0, 10))
        reach = np.hypot(wa.t_half_x, wa.t_half_y) + wa.t_radius
        return BlobPlan(
            cams=cams,
            robot=robot,
            mount=cam[:, 0] + 1j * cam[:, 1],
            mount_yaw=cam[:, 3],
            cam_z=cam[:, 2],
            fov=cam[:, 5],
            max_range=cam[:, 8],
            cam_channel=wa.channel[robot],
            cam_consts=np.column_stack([cam[:, 6] / 2, cam[:, 7] / 2, cam[:, 5], cam[:, 4],
                                        np.zeros(len(cams)), np.zeros(len(cams)),
                                        np.maximum(cam[:, 9], 1.0), cam[:, 6] - 1,
                                        cam[:, 7] - 1]),
            own=wa.own_body(robot, cam[:, 0] + 1j * cam[:, 1]),
            t_colour_index=wa.t_colour_index,
            t_colour=wa.t_colour,
            radius=wa.t_radius,
            half_x=wa.t_half_x,
            half_y=wa.t_half_y,
            z_top=wa.t_z_top,
            z_bottom=wa.t_z_bottom,
            reach=reach,
            bound=float(reach.max()) + 1e-6 if reach.size else 0.0,
            few=grid_index.one_cell(reach.size),
        )

    def pending(self, frame: Frame, t_pos: C128, t_head: C128, pan: F64, zoom: F64,
                hidden: NDArray[np.bool_] | None) -> Pending:
        """Pairs whose target lies within the camera's range and field of view.

        pan and zoom are per robot (zoom 0: the camera's own field of view); hidden marks
        targets that cannot be seen at all (stored objects).
        """
        if hidden is None:
            hidden = np.zeros(t_pos.shape[0], dtype=np.bool_)
        if t_pos.size < grid_index.FEW:
            grid = self.few
        else:
            grid = grid_index.build(t_pos.real.copy(), t_pos.imag.copy(),
                                    np.zeros(t_pos.size), (0.0, 0.0, 0.0, 0.0),
                                    typical_radius=float(self.max_range.max(initial=0.0)) / 4)
        slot, target, channel, origin, unit, rows = pending_near(
            self.robot, self.mount, self.mount_yaw, self.fov, self.max_range,
            self.cam_channel, self.t_colour_index, self.half_x, self.half_y, self.radius,
            self.bound, frame.pos, frame.head, frame.yaw, t_pos, t_head, pan, zoom, hidden,
            grid.params(), grid.start, grid.items)
        return Pending(slot, target, channel, origin, unit, rows[0], rows[1], rows[2],
                       rows[3], rows)

    def boxes(self, p: Pending, sel: NDArray[np.int64], tilt: F64, zoom: F64
              ) -> NDArray[np.int64]:
        """`blob_kernel.blob_boxes` of the pending pairs `sel` (none is a valid selection)."""
        slots = p.slot[sel]
        targets = p.target[sel]
        consts = self.cam_consts[slots]
        consts[:, DZ_TOP] = self.z_top[targets] - self.cam_z[slots]
        consts[:, DZ_BOTTOM] = self.z_bottom[targets] - self.cam_z[slots]
        return blob_boxes(self.robot[slots], consts, p.rows[:, sel], zoom, tilt)

    def project(self, p: Pending, visible: NDArray[np.bool_], pan: F64, tilt: F64,
                zoom: F64) -> list[tuple[BlobRow, ...]]:
        """Pinhole boxes of the visible pending pairs, per camera slot, as `BlobRow`s (the
        fields of a `Blob` in order), sorted by channel, then area (largest first), then x;
        pairs of equal keys keep their pending order."""
        out: list[list[BlobRow]] = [[] for _ in self.cams]
        sel = np.flatnonzero(visible)
        if sel.size == 0:
            return [() for _ in self.cams]
        slots = p.slot[sel]
        targets = p.target[sel]
        boxes = self.boxes(p, sel, tilt, zoom)
        seen = np.flatnonzero(boxes[:, 0])  # area 0: too small to see
        if seen.size == 0:
            return [() for _ in self.cams]
        boxes = boxes[seen]
        slots = slots[seen]
        channel = p.channel[sel][seen]
        # slot, then channel, area (largest first) and x; a stable sort keeps ties in order
        order = np.lexsort((boxes[:, 1], -boxes[:, 0], channel, slots))
        for (area, x, y, left, right, top, bottom), sl, ch, col, near in zip(
                boxes[order].tolist(), slots[order].tolist(), channel[order].tolist(),
                self.t_colour[targets[seen][order]].tolist(),
                p.near[sel][seen][order].tolist(), strict=True):
            out[sl].append((ch, col, area, x, y, left, right, top, bottom, near))
        return [tuple(rows) for rows in out]
