"""The footprint ray cast as one compiled loop (numba): the caster the simulation uses.

Every ray is tested against every footprint with the same geometry as the vectorised caster of
``footprint_cast`` (its reference in the tests): the centre relative to the ray, ``v = (c - o)
conj(d)``, culls a footprint whose bounding circle misses the ray's half-line or lies wholly
beyond the nearest hit found so far; a slab test finds the entry into a rectangle (none from
inside it), a quadratic the near side of a circle, the half planes of its edges the entry into
a convex polygon; footprints lower than the ray pass under it (and rays lower than a polygon's
bottom pass under the polygon); the room's walls bound every ray at most as tall as they are.
Compiled on first use and cached on disk next to this module (``cache=True``); divisions by
zero give inf/nan as in numpy (``error_model="numpy"``). The casts run without the interpreter
lock (``nogil``): `CompiledCaster` splits a big batch between the calling thread and a helper
of its own when the calling thread may run on two CPUs or more. Each ray's distance depends on
that ray alone, so the split changes no reading.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numba import njit

from player_server.sim import grid_index
from player_server.sim.footprint_cast import Footprints, Room

_PARALLEL = 1e-30  # nudges a direction component off zero: a huge finite slab time
_SLACK = 1e-6  # metres: a cell entered this little beyond the nearest hit is still visited
# Footprints beyond which rays walk the grid (`grid_index`) rather than test every footprint
GRID_MIN_FOOTPRINTS = 48
SPLIT_MIN_RAYS = 20_000
"""Rays from which a batch is cast in two halves at once (on two CPUs or more); below it
handing half to another thread costs more than it saves."""


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


# The helpers below take scalars only, and the casts index the arrays themselves: an array
# handed to a compiled function is reference-counted at every call, which in a loop over
# footprints made the cast ten times slower (bench/sim_speed.py; docs/performance.md).


@njit(cache=True, error_model="numpy")
def _beside(c: complex, r: float, ox: float, oy: float, dx: float, dy: float, b: float
            ) -> tuple[float, float, bool]:
    """A footprint's centre c relative to the unit ray: (along it, beside it, whether its
    bounding circle of radius r can hold a hit nearer than b)."""
    cx = c.real - ox
    cy = c.imag - oy
    vr = cx * dx + cy * dy
    vi = cy * dx - cx * dy
    return vr, vi, not (-vr > r or abs(vi) > r or vr - r > b)


@njit(cache=True, error_model="numpy")
def _rect_hit(vr: float, vi: float, dx: float, dy: float, head_conj: complex, half: complex,
              b: float) -> float:
    """Distance along the unit ray to the rectangle whose centre is (vr, vi) in the ray's
    frame (head_conj exp(-i yaw), complex half extents) when nearer than b, else inf (also
    for a ray starting inside it): the slab test in the rectangle's frame."""
    hr = head_conj.real
    hi = head_conj.imag
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
    bx = abs(ix) * half.real
    by = abs(iy) * half.imag
    t_near = max(ax - bx, ay - by)
    if t_near > 0.0 and t_near <= min(ax + bx, ay + by) and t_near < b:
        return t_near
    return np.inf


@njit(cache=True, error_model="numpy")
def _circle_hit(vr: float, vi: float, r: float, b: float) -> float:
    """Distance along the unit ray to the near side of the circle of radius r centred at
    (vr, vi) in the ray's frame when nearer than b, else inf."""
    disc = r * r - vi * vi
    if disc < 0.0:
        disc = 0.0
    t = vr - math.sqrt(disc)
    if t > 0.0 and t < b:
        return t
    return np.inf


@njit(cache=True, error_model="numpy")
def _poly_hit(p: int, ox: float, oy: float, dx: float, dy: float, b: float,
              poly_start: np.ndarray, poly_vert: np.ndarray) -> float:
    """Distance along the unit ray to convex polygon p (anticlockwise vertices) when it is
    nearer than b, else inf (also for a ray starting inside it): the ray clipped by the half
    plane of every edge (Cyrus-Beck)."""
    t_in = -np.inf
    t_out = np.inf
    lo = poly_start[p]
    hi = poly_start[p + 1]
    for k in range(lo, hi):
        ax = poly_vert[k].real
        ay = poly_vert[k].imag
        nxt = k + 1 if k + 1 < hi else lo
        nx = poly_vert[nxt].imag - ay  # the edge turned clockwise: outwards
        ny = ax - poly_vert[nxt].real
        num = (ax - ox) * nx + (ay - oy) * ny  # >= 0 where the origin is inside
        den = dx * nx + dy * ny  # < 0 where the ray goes in
        if den < 0.0:
            t = num / den
            if t > t_in:
                t_in = t
        elif den > 0.0:
            t = num / den
            if t < t_out:
                t_out = t
        elif num < 0.0:
            return np.inf  # beside an edge it runs along
    if t_in > 0.0 and t_in <= t_out and t_in < b:
        return t_in
    return np.inf


@njit(cache=True, error_model="numpy")
def _ray(o: complex, d: complex, z: float, limit: float, has_room: bool, hx: float,
         hy: float, wall_top: float) -> tuple[float, float, float, float, float]:
    """A ray's origin and direction as (ox, oy, dx, dy), and how far it may go: its limit, or
    the arena's wall (half sizes hx, hy, height wall_top) if nearer and the ray is no higher
    than the wall."""
    ox = o.real
    oy = o.imag
    dx = d.real
    dy = d.imag
    b = limit
    if has_room and z <= wall_top:
        w = _wall(ox, oy, dx, dy, hx, hy)
        if w < b:
            b = w
    return ox, oy, dx, dy, b


@njit(cache=True, error_model="numpy")
def _slab(o: float, d: float, lo: float, hi: float, t_in: float, t_out: float
          ) -> tuple[float, float]:
    """(t_in, t_out) narrowed to where a ray along one axis (origin o, direction d) lies
    between lo and hi; t_out -1 if it never does."""
    if d != 0.0:
        ta = (lo - o) / d
        tb = (hi - o) / d
        return max(t_in, min(ta, tb)), min(t_out, max(ta, tb))
    if o < lo or o > hi:
        return t_in, -1.0
    return t_in, t_out


@njit(cache=True, error_model="numpy")
def _axis_step(o: float, d: float, lo: float, cell: float, at: int) -> tuple[int, float, float]:
    """Along one axis, for a ray in cell `at` (cells of side `cell` from `lo`): the cell step
    (-1, 0, 1), the ray parameter at the next cell boundary, and between boundaries."""
    if d > 0.0:
        return 1, (lo + (at + 1) * cell - o) / d, cell / d
    if d < 0.0:
        return -1, (lo + at * cell - o) / d, -cell / d
    return 0, np.inf, np.inf


@njit(cache=True, error_model="numpy", nogil=True)
def cast_rays(o: np.ndarray, d: np.ndarray, limit: np.ndarray, z: np.ndarray,
              own: np.ndarray, centre: np.ndarray, head_conj: np.ndarray, half: np.ndarray,
              radius: np.ndarray, top: np.ndarray, room: np.ndarray, poly_start: np.ndarray,
              poly_vert: np.ndarray, poly_bottom: np.ndarray) -> np.ndarray:
    """Distance along each unit ray (complex origin o, direction d, height z) to the nearest
    footprint at least as tall as the ray or wall, else its limit.

    Footprints: complex centres (rectangles first, then polygons, then circles), head_conj
    exp(-i yaw) and complex half extents of each rectangle, bounding radius and top of each.
    own (per ray): a footprint the ray starts inside, which it cannot see, or -1. room:
    (half_x, half_y, top) of the arena's walls, or empty for none. Convex polygons come between
    the rectangles and the circles (see `Footprints`: their vertex offsets, vertices and
    bottoms).
    """
    n = o.shape[0]
    n_rect = head_conj.shape[0]
    poly_end = n_rect + poly_start.shape[0] - 1
    has_room = room.shape[0] == 3
    hx, hy, wall_top = (room[0], room[1], room[2]) if has_room else (0.0, 0.0, 0.0)
    best = np.empty(n)
    for i in range(n):
        ox, oy, dx, dy, b = _ray(o[i], d[i], z[i], limit[i], has_room, hx, hy, wall_top)
        zi = z[i]
        skip = own[i]
        for f in range(centre.shape[0]):
            if f == skip or top[f] < zi:
                continue
            vr, vi, near = _beside(centre[f], radius[f], ox, oy, dx, dy, b)
            if not near:
                continue
            if f < n_rect:
                t = _rect_hit(vr, vi, dx, dy, head_conj[f], half[f], b)
            elif f < poly_end:
                if poly_bottom[f - n_rect] > zi:
                    continue  # the ray passes under the polygon
                t = _poly_hit(f - n_rect, ox, oy, dx, dy, b, poly_start, poly_vert)
            else:
                t = _circle_hit(vr, vi, radius[f], b)
            if t < b:
                b = t
        best[i] = b
    return best


@njit(cache=True, error_model="numpy", nogil=True)
def cast_rays_grid(o: np.ndarray, d: np.ndarray, limit: np.ndarray, z: np.ndarray,
                   own: np.ndarray, centre: np.ndarray, head_conj: np.ndarray,
                   half: np.ndarray, radius: np.ndarray, top: np.ndarray, room: np.ndarray,
                   poly_start: np.ndarray, poly_vert: np.ndarray, poly_bottom: np.ndarray,
                   gp: np.ndarray, start: np.ndarray, items: np.ndarray) -> np.ndarray:
    """As `cast_rays`, visiting only the footprints listed in the grid cells (`grid_index`)
    that each ray passes through, nearest first, until a cell begins beyond the nearest hit
    found. Each footprint is tested as in `cast_rays`, so the readings are the same."""
    n = o.shape[0]
    k = centre.shape[0]
    n_rect = head_conj.shape[0]
    poly_end = n_rect + poly_start.shape[0] - 1
    has_room = room.shape[0] == 3
    hx, hy, wall_top = (room[0], room[1], room[2]) if has_room else (0.0, 0.0, 0.0)
    x0 = gp[0]
    y0 = gp[1]
    cell = gp[2]
    nx = int(gp[3])
    ny = int(gp[4])
    x1 = x0 + nx * cell
    y1 = y0 + ny * cell
    mark = np.full(k, -1, np.int64)  # the last ray that tested each footprint
    best = np.empty(n)
    for i in range(n):
        ox, oy, dx, dy, b = _ray(o[i], d[i], z[i], limit[i], has_room, hx, hy, wall_top)
        zi = z[i]
        skip = own[i]
        if not (math.isfinite(ox) and math.isfinite(oy) and math.isfinite(dx)
                and math.isfinite(dy)) or (dx == 0.0 and dy == 0.0):
            # no cell to start from, or no way to go: every footprint, as cast_rays does
            best[i] = cast_rays(o[i:i + 1], d[i:i + 1], limit[i:i + 1], z[i:i + 1],
                                own[i:i + 1], centre, head_conj, half, radius, top, room,
                                poly_start, poly_vert, poly_bottom)[0]
            continue
        # The part of the ray inside the grid's box.
        t_in, t_out = _slab(ox, dx, x0, x1, 0.0, b)
        t_in, t_out = _slab(oy, dy, y0, y1, t_in, t_out)
        if t_in > t_out:
            best[i] = b
            continue
        ix = grid_index.cell_of(ox + dx * t_in, x0, cell, nx)
        iy = grid_index.cell_of(oy + dy * t_in, y0, cell, ny)
        # Amanatides-Woo traversal: the ray parameter at the next x and y cell boundary.
        step_x, t_max_x, t_dx = _axis_step(ox, dx, x0, cell, ix)
        step_y, t_max_y, t_dy = _axis_step(oy, dy, y0, cell, iy)
        while True:
            c = iy * nx + ix
            for j in range(start[c], start[c + 1]):
                f = items[j]
                if mark[f] == i:
                    continue
                mark[f] = i
                if f == skip or top[f] < zi:
                    continue
                vr, vi, near = _beside(centre[f], radius[f], ox, oy, dx, dy, b)
                if not near:
                    continue
                if f < n_rect:
                    t = _rect_hit(vr, vi, dx, dy, head_conj[f], half[f], b)
                elif f < poly_end:
                    if poly_bottom[f - n_rect] > zi:
                        continue
                    t = _poly_hit(f - n_rect, ox, oy, dx, dy, b, poly_start, poly_vert)
                else:
                    t = _circle_hit(vr, vi, radius[f], b)
                if t < b:
                    b = t
            if t_max_x < t_max_y:
                t_entry = t_max_x
                ix += step_x
                t_max_x += t_dx
                if ix < 0 or ix >= nx:
                    break
            else:
                t_entry = t_max_y
                iy += step_y
                t_max_y += t_dy
                if iy < 0 or iy >= ny:
                    break
            if t_entry > b + _SLACK:
                break
        best[i] = b
    return best


_NO_ROOM = np.zeros(0)


class CompiledCaster:
    """`FootprintCaster`'s interface over `cast_rays`, or `cast_rays_grid` when there are at
    least ``grid_min`` footprints. A batch of at least ``split_min`` rays is cast in two
    halves at once, the second by the caster's helper thread (started on first use, ended by
    `close`), when the calling thread may run on two CPUs or more (a serving thread pinned
    to one CPU never splits). Owns no state between calls but that thread."""

    def __init__(self, grid_min: int = GRID_MIN_FOOTPRINTS,
                 split_min: int = SPLIT_MIN_RAYS) -> None:
        self.grid_min = grid_min
        self.split_min = split_min
        self._helper: ThreadPoolExecutor | None = None

    def cast(self, o: np.ndarray, d: np.ndarray, limit: np.ndarray, z: np.ndarray,
             fp: Footprints, room: Room | None, own: np.ndarray | None = None) -> np.ndarray:
        """Distance along each unit ray (origin o, direction d, height z) to the nearest
        footprint (or wall) at least as tall as z, or ``limit`` when nothing is nearer; own
        (optional, per ray) is a footprint the ray starts inside, or -1."""
        n = o.shape[0]
        if own is None:
            own = np.full(n, -1, dtype=np.int64)
        walls = _NO_ROOM if room is None else np.array([room.half_x, room.half_y, room.top])
        rays = (np.ascontiguousarray(o, dtype=np.complex128),
                np.ascontiguousarray(d, dtype=np.complex128),
                np.ascontiguousarray(limit, dtype=np.float64),
                np.ascontiguousarray(z, dtype=np.float64),
                np.ascontiguousarray(own, dtype=np.int64))
        scene: tuple[np.ndarray, ...] = (fp.centre, fp.head_conj, fp.half, fp.radius, fp.top,
                                         walls, fp.poly_start, fp.poly_vert, fp.poly_bottom)
        kernel: Any = cast_rays
        if fp.count >= self.grid_min and n > 0:
            grid = footprint_grid(fp, room)
            scene = (*scene, grid.params(), grid.start, grid.items)
            kernel = cast_rays_grid
        if n < self.split_min or not _two_cpus():
            return kernel(*rays, *scene)
        half = n // 2
        if self._helper is None:
            self._helper = ThreadPoolExecutor(1, thread_name_prefix="ray-cast-helper")
        later = self._helper.submit(kernel, *(r[half:] for r in rays), *scene)
        first = kernel(*(r[:half] for r in rays), *scene)
        return np.concatenate((first, later.result()))

    def close(self) -> None:
        """End the helper thread (a later split starts another)."""
        helper, self._helper = self._helper, None
        if helper is not None:
            helper.shutdown(wait=True)


def _two_cpus() -> bool:
    """May the calling thread run on two CPUs or more?"""
    getter = getattr(os, "sched_getaffinity", None)
    if getter is None:
        return (os.cpu_count() or 1) >= 2
    try:
        return len(getter(0)) >= 2
    except OSError:
        return False


def footprint_grid(fp: Footprints, room: Room | None) -> grid_index.Grid:
    """The grid of the footprints' bounding circles over the room (cached per Footprints)."""
    got = fp._cull.get("grid")
    if isinstance(got, grid_index.Grid):
        return got
    bounds = (0.0, 0.0, 0.0, 0.0) if room is None else (-room.half_x, -room.half_y,
                                                       room.half_x, room.half_y)
    grid = grid_index.build(fp.centre.real.copy(), fp.centre.imag.copy(), fp.radius, bounds)
    fp._cull["grid"] = grid  # type: ignore[assignment]
    return grid
