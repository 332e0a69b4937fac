"""The footprint ray cast as one compiled loop (numba): the caster the simulation uses.

Every ray is tested against every footprint with the same geometry as the vectorised caster of
``footprint_cast`` (its reference in the tests): the centre relative to the ray,
``v = (c - o) conj(d)``, culls a footprint whose bounding circle misses the ray's half-line or
lies wholly beyond the nearest hit found so far; a slab test finds the entry into a rectangle
(none from inside it), a quadratic the near side of a circle; footprints lower than the ray
pass under it; the room's walls bound every ray at most as tall as they are. Compiled on first
use and cached on disk next to this module (``cache=True``); divisions by zero give inf/nan as
in numpy (``error_model="numpy"``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from player_server.sim.footprint_cast import Footprints, Room

_PARALLEL = 1e-30  # nudges a direction component off zero: a huge finite slab time


@njit(cache=True, error_model="numpy")
def _wall(ox: float, oy: float, dx: float, dy: float, hx: float, hy: float) -> float:
    """Distance along a unit ray to the wall ahead of a room centred on the origin (inf for a
    ray starting outside the room that never meets an inner face)."""
    tx = (math.copysign(hx, dx) - ox) / dx
    ty = (math.copysign(hy, dy) - oy) / dy
    if tx != tx:
        t = ty
    elif ty != ty:
        t = tx
    else:
        t = min(tx, ty)
    if not t >= 0.0:
        return np.inf
    return t


@njit(cache=True, error_model="numpy")
def cast_rays(o: np.ndarray, d: np.ndarray, limit: np.ndarray, z: np.ndarray,
              own: np.ndarray, centre: np.ndarray, head_conj: np.ndarray, half: np.ndarray,
              radius: np.ndarray, top: np.ndarray, room: np.ndarray) -> np.ndarray:
    """Distance along each unit ray (complex origin o, direction d, height z) to the nearest
    footprint at least as tall as the ray or wall, else its limit.

    Footprints: complex centres (rectangles first, then circles), head_conj exp(-i yaw) and
    complex half extents of each rectangle, bounding radius and top of each. own (per ray):
    a footprint the ray starts inside, which it cannot see, or -1. room: (half_x, half_y, top)
    of the arena's walls, or empty for none.
    """
    n = o.shape[0]
    k = centre.shape[0]
    n_rect = head_conj.shape[0]
    has_room = room.shape[0] == 3
    best = np.empty(n)
    for i in range(n):
        ox = o[i].real
        oy = o[i].imag
        dx = d[i].real
        dy = d[i].imag
        zi = z[i]
        b = limit[i]
        if has_room and zi <= room[2]:
            w = _wall(ox, oy, dx, dy, room[0], room[1])
            if w < b:
                b = w
        skip = own[i]
        for f in range(k):
            if f == skip or top[f] < zi:
                continue
            cx = centre[f].real - ox
            cy = centre[f].imag - oy
            vr = cx * dx + cy * dy  # along the ray
            vi = cy * dx - cx * dy  # beside it
            r = radius[f]
            if -vr > r or abs(vi) > r or vr - r > b:
                continue
            if f < n_rect:
                hr = head_conj[f].real
                hi = head_conj[f].imag
                qx = dx * hr - dy * hi  # the direction in the rectangle's frame
                qy = dx * hi + dy * hr
                px = vr * qx - vi * qy  # the centre relative to the origin, same frame
                py = vr * qy + vi * qx
                qx += math.copysign(_PARALLEL, qx)
                qy += math.copysign(_PARALLEL, qy)
                ix = 1.0 / qx
                iy = 1.0 / qy
                ax = px * ix
                ay = py * iy
                bx = abs(ix) * half[f].real
                by = abs(iy) * half[f].imag
                t_near = max(ax - bx, ay - by)
                if t_near > 0.0 and t_near <= min(ax + bx, ay + by) and t_near < b:
                    b = t_near
            else:
                disc = r * r - vi * vi
                if disc < 0.0:
                    disc = 0.0
                t = vr - math.sqrt(disc)
                if t > 0.0 and t < b:
                    b = t
        best[i] = b
    return best


_NO_ROOM = np.zeros(0)


class CompiledCaster:
    """`FootprintCaster`'s interface over `cast_rays` (owns no state between calls)."""

    def cast(self, o: np.ndarray, d: np.ndarray, limit: np.ndarray, z: np.ndarray,
             fp: Footprints, room: Room | None, own: np.ndarray | None = None) -> np.ndarray:
        """Distance along each unit ray (origin o, direction d, height z) to the nearest
        footprint (or wall) at least as tall as z, or ``limit`` when nothing is nearer; own
        (optional, per ray) is a footprint the ray starts inside, or -1."""
        n = o.shape[0]
        if own is None:
            own = np.full(n, -1, dtype=np.int64)
        walls = _NO_ROOM if room is None else np.array([room.half_x, room.half_y, room.top])
        return cast_rays(np.ascontiguousarray(o, dtype=np.complex128),
                         np.ascontiguousarray(d, dtype=np.complex128),
                         np.ascontiguousarray(limit, dtype=np.float64),
                         np.ascontiguousarray(z, dtype=np.float64),
                         np.ascontiguousarray(own, dtype=np.int64), fp.centre, fp.head_conj,
                         fp.half, fp.radius, fp.top, walls)
