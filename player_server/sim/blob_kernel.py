"""The fast blobfinder's per-pair geometry as compiled loops (numba).

`BlobPlan.pending` and `BlobPlan.project` (``fastsense``) call these; the formulas are theirs,
restated per (camera, target) pair:

- `pending_near`: the (camera, target) pairs whose target's colour the camera tracks and
  that lie within its range and field of view (the near side in range, the angular extent
  overlapping the field of view, not hidden), looking only at the targets listed near the
  camera in a grid of the targets (`grid_index`);
- `blob_boxes`: the pinhole box of each pair that passed the occlusion test, and its area.

Compiled on first use and cached on disk next to this module (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from player_server.sim.grid_index import near_disc

_LIM = math.radians(89.0)  # edge angles are clipped to +-89 degrees before tan()
_NEAR_MIN = 1e-3  # a target closer than this (inside the camera) is not seen
# columns of the plan's per-pair constants (BlobPlan.consts)
_HW, _HH, _FOV, _TILT, _DZT, _DZB, _MIN_AREA, _W1, _H1 = range(9)
DZ_TOP, DZ_BOTTOM = _DZT, _DZB


@njit(cache=True, error_model="numpy")
def pending_near(cam_robot: np.ndarray, mount: np.ndarray, mount_yaw: np.ndarray,
                 fov: np.ndarray, max_range: np.ndarray, cam_channel: np.ndarray,
                 t_colour: np.ndarray, half_x: np.ndarray, half_y: np.ndarray,
                 radius: np.ndarray, bound: float, pos: np.ndarray, head: np.ndarray,
                 yaw: np.ndarray, t_pos: np.ndarray, t_head: np.ndarray, pan: np.ndarray,
                 zoom: np.ndarray, hidden: np.ndarray, gp: np.ndarray, start: np.ndarray,
                 items: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                             np.ndarray, np.ndarray, np.ndarray]:
    """(camera, target) pairs in range and in view, cameras in order and each camera's
    targets in increasing order: their camera slots, targets, channels, camera origins, unit
    directions to the target centres, and (dist, near, bearing, half) rows.

    Per camera: its robot, mount (complex, robot frame), mount yaw, field of view, range, and
    the channel tracking each colour (-1: none). Per target: its colour's index, half extents
    (rectangles) or radius (circles); bound: the largest reach of a target from its centre.
    Per robot: position, heading exp(i yaw), yaw, pan and zoom (0: the camera's own field of
    view). Per target: position, heading, hidden (cannot be seen at all). Only the targets
    listed in the grid (`grid_index`, over the targets' centres) near each camera are looked
    at: a target whose centre is further than range + bound cannot be in range.
    """
    n_cams = cam_robot.shape[0]
    n_t = t_pos.shape[0]
    mark = np.full(n_t, -1, np.int64)
    near_t = np.empty(n_t, np.int64)
    cap = 64
    slot_o = np.empty(cap, np.int64)
    target_o = np.empty(cap, np.int64)
    channel_o = np.empty(cap, np.int64)
    origin = np.empty(cap, np.complex128)
    unit = np.empty(cap, np.complex128)
    rows = np.empty((4, cap))
    k = 0
    for p in range(n_cams):
        r = cam_robot[p]
        o = pos[r] + head[r] * mount[p]
        m = near_disc(o.real, o.imag, max_range[p] + bound, gp, start, items, mark, p,
                      near_t)
        cands = np.sort(near_t[:m])
        for t in cands:
            ch = cam_channel[p, t_colour[t]]
            if ch < 0 or t == r or hidden[t]:
                continue
            v = t_pos[t] - o
            dist = abs(v)
            u = v / max(dist, 1e-9)
            # The target's orientation relative to the line of sight: its half width across
            # the line and its half depth along it (plus the radius of a circle, whose
            # extents are 0).
            rel = t_head[t] * u.conjugate()
            c = abs(rel.real)
            s = abs(rel.imag)
            across = half_x[t] * s + half_y[t] * c + radius[t]
            along = half_x[t] * c + half_y[t] * s + radius[t]
            near = dist - along
            if not (near <= max_range[p] and near > _NEAR_MIN):
                continue
            half = math.asin(min(across / max(dist, 1e-6), 1.0))
            cam_yaw = yaw[r] + mount_yaw[p] + pan[r]
            w = u * complex(math.cos(cam_yaw), -math.sin(cam_yaw))
            bearing = math.atan2(w.imag, w.real)
            f = zoom[r] if zoom[r] > 0 else fov[p]
            if abs(bearing) - half < f / 2:
                if k == cap:
                    cap *= 2
                    slot_o = _grown(slot_o, cap)
                    target_o = _grown(target_o, cap)
                    channel_o = _grown(channel_o, cap)
                    origin = _grown(origin, cap)
                    unit = _grown(unit, cap)
                    bigger = np.empty((4, cap))
                    bigger[:, :k] = rows[:, :k]
                    rows = bigger
                slot_o[k] = p
                target_o[k] = t
                channel_o[k] = ch
                origin[k] = o
                unit[k] = u
                rows[0, k] = dist
                rows[1, k] = near
                rows[2, k] = bearing
                rows[3, k] = half
                k += 1
    return (slot_o[:k], target_o[:k], channel_o[:k], origin[:k], unit[:k],
            np.ascontiguousarray(rows[:, :k]))


@njit(cache=True)
def _grown(a: np.ndarray, cap: int) -> np.ndarray:
    b = np.empty(cap, a.dtype)
    b[:a.shape[0]] = a
    return b


@njit(cache=True, error_model="numpy")
def blob_boxes(robot: np.ndarray, consts: np.ndarray, rows: np.ndarray, zoom: np.ndarray,
               tilt: np.ndarray) -> np.ndarray:
    """Per visible pair (its robot, the plan's constants row, its (dist, near, bearing, half)
    row): area, centre x, y and box left, right, top, bottom in pixels (area 0: too small)."""
    n = robot.shape[0]
    out = np.zeros((n, 7), np.int64)
    for p in range(n):
        r = robot[p]
        c = consts[p]
        dist = rows[0, p]
        near = rows[1, p]
        b = rows[2, p]
        half = rows[3, p]
        hw = c[_HW]
        hh = c[_HH]
        z = zoom[r]
        f = hw / math.tan((z if z > 0 else c[_FOV]) / 2)
        # Horizontal: the angular edges (left is the larger angle, hence smaller x).
        left = max(math.ceil(hw - f * math.tan(min(b + half, _LIM))), 0)
        right = min(math.floor(hw - f * math.tan(max(b - half, -_LIM))), int(c[_W1]))
        # Vertical: the top edge is the top at the near side when above the camera, else at
        # the far side; the bottom edge likewise.
        cos_b = max(math.cos(b), 1e-3)
        near_d = near * cos_b
        far_d = (2.0 * dist - near) * cos_b
        tilt_all = c[_TILT] + tilt[r]
        dz_t = c[_DZT]
        dz_b = c[_DZB]
        e_top = math.atan2(dz_t, near_d if dz_t > 0 else far_d) - tilt_all
        e_bot = math.atan2(dz_b, near_d if dz_b < 0 else far_d) - tilt_all
        top = max(math.ceil(hh - f * math.tan(min(e_top, _LIM))), 0)
        bottom = min(math.floor(hh - f * math.tan(max(e_bot, -_LIM))), int(c[_H1]))
        area = max(right - left + 1, 0) * max(bottom - top + 1, 0)
        if area >= c[_MIN_AREA]:
            out[p, 0] = area
            out[p, 1] = (left + right) // 2
            out[p, 2] = (top + bottom) // 2
            out[p, 3] = left
            out[p, 4] = right
            out[p, 5] = top
            out[p, 6] = bottom
    return out
