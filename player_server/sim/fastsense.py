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
from player_server.sim.sensing import WorldArrays
from worlds import RobotSpec

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]
_LIM = float(np.radians(89.0))


@dataclass(frozen=True)
class Frame:
    """Robot poses at one tick: axle-centre position, heading, yaw (per robot)."""

    pos: C128
    head: C128
    yaw: F64


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

    @staticmethod
    def build(cams: tuple[int, ...], wa: WorldArrays) -> BlobPlan:
        ch = wa.channel[list(cams)] if cams else np.zeros((0, wa.t_radius.size), np.int64)
        slot, target = np.nonzero(ch >= 0)
        robot = np.array(cams, dtype=np.int64)[slot] if cams else slot
        cam = wa.cam[robot]
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
            w, h = self.width[idx], self.height[idx]
            fov = np.where(zoom[r] > 0, zoom[r], self.fov[idx])
            f = (w / 2) / np.tan(fov / 2)
            b, half = p.bearing[visible], p.half[visible]
            near = p.near[visible]
            # Horizontal: the angular edges (left is the larger angle, hence smaller x).
            left = np.maximum(np.ceil(w / 2 - f * np.tan(np.minimum(b + half, _LIM))), 0)
            right = np.minimum(np.floor(w / 2 - f * np.tan(np.maximum(b - half, -_LIM))), w - 1)
            # Vertical: the top edge is the top at the near side when above the camera, else
            # at the far side; the bottom edge likewise.
            cos_b = np.maximum(np.cos(b), 1e-3)
            near_d = near * cos_b
            far_d = (2.0 * p.dist[visible] - near) * cos_b
            dz_t, dz_b = self.dz_top[idx], self.dz_bottom[idx]
            tilt_all = self.tilt[idx] + tilt[r]
            e_top = np.arctan2(dz_t, np.where(dz_t > 0, near_d, far_d)) - tilt_all
            e_bot = np.arctan2(dz_b, np.where(dz_b < 0, near_d, far_d)) - tilt_all
            top = np.maximum(np.ceil(h / 2 - f * np.tan(np.minimum(e_top, _LIM))), 0)
            bottom = np.minimum(np.floor(h / 2 - f * np.tan(np.maximum(e_bot, -_LIM))), h - 1)
            area = np.maximum(right - left + 1, 0) * np.maximum(bottom - top + 1, 0)
            ok = area >= self.min_area[idx]
            rows = zip(self.slot[idx][ok].tolist(), self.channel[idx][ok].tolist(),
                       self.colour[idx][ok].tolist(), area[ok].tolist(), left[ok].tolist(),
                       right[ok].tolist(), top[ok].tolist(), bottom[ok].tolist(),
                       near[ok].tolist(), strict=True)
            for sl, ch, col, ar, lf, rt, tp, bt, rng in rows:
                li, ri, ti, bi = int(lf), int(rt), int(tp), int(bt)
                out[sl].append(Blob(ch, col, int(ar), (li + ri) // 2, (ti + bi) // 2, li, ri, ti,
                                    bi, rng))
        return [tuple(sorted(bl, key=lambda b: (b.id, -b.area, b.x))) for bl in out]
