"""Per-tick vectorised geometry for the fast sensors (pure numpy).

Planar poses are complex numbers: a position ``x + iy`` and a heading ``exp(i yaw)``, so a
robot-frame offset ``l`` lands at ``pos + head * l`` in one multiply-add for every ray or
camera at once. Plans (which rays, which camera/target pairs) are built once per set of active
sensors; each tick only evaluates them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from player_server.sim.readings import Blob
from player_server.sim.world_arrays import WorldArrays
from worlds import RobotSpec

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]
_LIM = float(np.radians(89.0))
# Edge angles are kept off +-90 deg on their outer side: left and top below +89 deg, right and
# bottom above -89 deg (per row of the (4, n) edge arrays).
_ANGLE_MIN = np.array([[-np.inf], [-_LIM], [-np.inf], [-_LIM]])
_ANGLE_MAX = np.array([[_LIM], [np.inf], [_LIM], [np.inf]])


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

    @staticmethod
    def build(keys: tuple[tuple[int, str], ...], robots: tuple[RobotSpec, ...]) -> RangePlan:
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
                la = np.array(d.angles_rad()) + d.pose.yaw
                local = np.full(la.size, complex(d.pose.x, d.pose.y))
                z = d.pose.z
            parts.append((idx, local, np.exp(1j * la), z, d.min_range_m, d.max_range_m, k))
        counts = tuple(p[1].size for p in parts)
        return RangePlan(
            keys=keys,
            robot=np.repeat([p[0] for p in parts], counts).astype(np.int64),
            local=np.concatenate([p[1] for p in parts]),
            unit=np.concatenate([p[2] for p in parts]),
            z=np.repeat([p[3] for p in parts], counts).astype(np.float64),
            min_range=np.repeat([p[4] for p in parts], counts).astype(np.float64),
            max_range=np.repeat([p[5] for p in parts], counts).astype(np.float64),
            counts=counts,
            groups=tuple(p[6] for p in parts),
        )

    def rays(self, frame: Frame) -> tuple[C128, C128]:
        """World origins and unit directions of every ray."""
        head = frame.head[self.robot]
        return frame.pos[self.robot] + head * self.local, head * self.unit

    def split(self, ranges: F64) -> dict[tuple[int, str], np.ndarray]:
        """Per-sensor readings (cone minima, clipped to each sensor's limits), read-only."""
        r = np.minimum(np.maximum(ranges, self.min_range), self.max_range)
        r32 = r.astype(np.float32)
        r32.setflags(write=False)
        out: dict[tuple[int, str], np.ndarray] = {}
        start = 0
        for key, n, g in zip(self.keys, self.counts, self.groups, strict=True):
            stop = start + n
            if key[1] == "ranger":
                part: np.ndarray = r[start:stop].copy()
                part.setflags(write=False)
            elif g > 1:
                part = r32[start:stop].reshape(-1, g).min(axis=1)
                part.setflags(write=False)
            else:
                part = r32[start:stop]
            out[key] = part
            start = stop
        return out


@dataclass(frozen=True)
class Pending:
    """Camera/target pairs in range and in view, awaiting the occlusion test."""

    pair: NDArray[np.int64]  # index into the plan's pair arrays
    origin: C128  # camera position (occlusion ray origin)
    direction: C128  # unit vector to the target centre
    dist: F64
    near: F64
    bearing: F64  # relative to the camera axis, anticlockwise
    half: F64  # angular half-width


@dataclass(frozen=True)
class BlobPlan:
    """Every (camera, target) pair whose colour the camera's blobfinder tracks."""

    cams: tuple[int, ...]
    slot: NDArray[np.int64]
    robot: NDArray[np.int64]
    target: NDArray[np.int64]
    channel: NDArray[np.int64]
    colour: NDArray[np.int64]
    mount: C128
    mount_yaw: F64
    cam_z: F64
    tilt: F64
    fov: F64
    width: F64
    height: F64
    max_range: F64
    min_area: F64
    radius: F64
    half_x: F64
    half_y: F64
    dz_top: F64
    dz_bottom: F64
    circle: NDArray[np.bool_]
    half_size: F64  # (4, pairs): width/2, width/2, height/2, height/2 (pixel edge origins)
    edge_min: F64  # (4, pairs): 0, -inf, 0, -inf
    edge_max: F64  # (4, pairs): inf, width - 1, inf, height - 1
    meta: NDArray[np.int64]  # (3, pairs): camera slot, channel, colour

    @staticmethod
    def build(cams: tuple[int, ...], wa: WorldArrays) -> BlobPlan:
        ch = wa.channel[list(cams)] if cams else np.zeros((0, wa.t_radius.size), np.int64)
        slot, target = np.nonzero(ch >= 0)
        robot = np.array(cams, dtype=np.int64)[slot] if cams else slot
        cam = wa.cam[robot]
        zero = np.zeros(slot.size)
        inf = np.full(slot.size, np.inf)
        return BlobPlan(
            cams=cams,
            slot=slot,
            robot=robot,
            target=target,
            channel=ch[slot, target],
            colour=wa.t_colour[target],
            mount=cam[:, 0] + 1j * cam[:, 1],
            mount_yaw=cam[:, 3],
            cam_z=cam[:, 2],
            tilt=cam[:, 4],
            fov=cam[:, 5],
            width=cam[:, 6],
            height=cam[:, 7],
            max_range=cam[:, 8],
            min_area=np.maximum(cam[:, 9], 1.0),
            radius=wa.t_radius[target],
            half_x=wa.t_half_x[target],
            half_y=wa.t_half_y[target],
            dz_top=wa.t_z_top[target] - cam[:, 2],
            dz_bottom=wa.t_z_bottom[target] - cam[:, 2],
            circle=wa.t_radius[target] > 0,
            half_size=np.stack([cam[:, 6] / 2, cam[:, 6] / 2, cam[:, 7] / 2, cam[:, 7] / 2]),
            edge_min=np.stack([zero, -inf, zero, -inf]),
            edge_max=np.stack([inf, cam[:, 6] - 1, inf, cam[:, 7] - 1]),
            meta=np.stack([slot, ch[slot, target], wa.t_colour[target]]).astype(np.int64),
        )

    def pending(self, frame: Frame, t_pos: C128, t_head: C128, pan: F64, zoom: F64,
                hidden: NDArray[np.bool_] | None) -> Pending:
        """Pairs whose target lies within the camera's range and field of view.

        pan and zoom are per robot (zoom 0: the camera's own field of view); hidden marks
        targets that cannot be seen at all (stored objects).
        """
        r = self.robot
        head = frame.head[r]
        origin = frame.pos[r] + head * self.mount
        v = t_pos[self.target] - origin
        dist = np.abs(v)
        unit = v / np.maximum(dist, 1e-9)
        # The target's orientation relative to the line of sight (for rectangles).
        rel = t_head[self.target] * unit.conjugate()
        c, s = np.abs(rel.real), np.abs(rel.imag)
        half_w = np.where(self.circle, self.radius, self.half_x * s + self.half_y * c)
        depth = np.where(self.circle, self.radius, self.half_x * c + self.half_y * s)
        near = dist - depth
        half = np.arcsin(np.minimum(half_w / np.maximum(dist, 1e-6), 1.0))
        cam_yaw = frame.yaw[r] + self.mount_yaw + pan[r]
        bearing = np.angle(unit * np.exp(-1j * cam_yaw))
        fov = np.where(zoom[r] > 0, zoom[r], self.fov)
        keep = (near <= self.max_range) & (np.abs(bearing) - half < fov / 2) & (near > 1e-3)
        if hidden is not None:
            keep &= ~hidden[self.target]
        idx = np.nonzero(keep)[0]
        return Pending(idx, origin[idx], unit[idx], dist[idx], near[idx], bearing[idx],
                       half[idx])

    def project(self, p: Pending, visible: NDArray[np.bool_], pan: F64, tilt: F64,
                zoom: F64) -> list[tuple[Blob, ...]]:
        """Pinhole boxes of the visible pending pairs, per camera slot (sorted by channel,
        then area, largest first)."""
        out: list[list[Blob]] = [[] for _ in self.cams]
        idx = p.pair[visible]
        if idx.size:
            r = self.robot[idx]
            zr = zoom[r]
            fov = np.where(zr > 0, zr, self.fov[idx])
            f = self.half_size[0, idx] / np.tan(fov / 2)
            b, half = p.bearing[visible], p.half[visible]
            near = p.near[visible]
            # Vertical: the top edge is the top at the near side when above the camera, else
            # at the far side; the bottom edge likewise.
            cos_b = np.maximum(np.cos(b), 1e-3)
            near_d = near * cos_b
            far_d = (2.0 * p.dist[visible] - near) * cos_b
            dz_t, dz_b = self.dz_top[idx], self.dz_bottom[idx]
            tilt_all = self.tilt[idx] + tilt[r]
            # The four edge angles: left, right (the larger angle is the smaller x), top,
            # bottom; then pixel edges, rounded inwards and clipped to the image.
            ang = np.empty((4, idx.size))
            np.add(b, half, out=ang[0])
            np.subtract(b, half, out=ang[1])
            np.arctan2(dz_t, np.where(dz_t > 0, near_d, far_d), out=ang[2])
            np.arctan2(dz_b, np.where(dz_b < 0, near_d, far_d), out=ang[3])
            ang[2:] -= tilt_all
            np.clip(ang, _ANGLE_MIN, _ANGLE_MAX, out=ang)
            edge = np.tan(ang)
            edge *= f
            np.subtract(self.half_size[:, idx], edge, out=edge)
            np.ceil(edge[0::2], out=edge[0::2])
            np.floor(edge[1::2], out=edge[1::2])
            np.clip(edge, self.edge_min[:, idx], self.edge_max[:, idx], out=edge)
            span = edge[1::2] - edge[0::2]
            span += 1
            np.maximum(span, 0, out=span)
            area = span[0] * span[1]
            sel = np.flatnonzero(area >= self.min_area[idx])
            if sel.size:
                vals = np.vstack([edge[:, sel], area[sel], near[sel]]).T.tolist()
                meta = self.meta[:, idx[sel]].T.tolist()
                for (sl, ch, col), (lf, rt, tp, bt, ar, rng) in zip(meta, vals, strict=True):
                    li, ri, ti, bi = int(lf), int(rt), int(tp), int(bt)
                    out[sl].append(Blob(ch, col, int(ar), (li + ri) // 2, (ti + bi) // 2, li,
                                        ri, ti, bi, rng))
        return [tuple(sorted(bl, key=lambda b: (b.id, -b.area, b.x))) for bl in out]
