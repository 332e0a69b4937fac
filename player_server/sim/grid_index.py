"""A uniform grid over discs (compiled with numba): the simulator's spatial index.

Things that sense one another each tick (rays against footprints, cameras against blob
targets, fiducial detectors against tagged bodies) would otherwise look at every thing for
every sensor, a cost quadratic in the number of robots. The grid is rebuilt each tick from
the discs that bound the things (centre and radius): a thing is listed in every cell that the
disc's bounding square overlaps (padded by `PAD`), cells in compressed rows (``start`` and
``items``, as a sparse matrix stores its rows). Building it is linear in the things; a query
visits only the cells it touches.

The grid covers a box given by the caller (the room, grown to hold every disc); its cell is
about the size that holds a few things each (`layout`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

PAD = 1e-6  # metres: a disc touching a cell boundary is listed on both sides
MAX_CELLS_PER_THING = 4  # about this many cells per thing at most (the grid's memory bound)
MIN_CELL = 0.25  # metres
FEW = 48  # below this many things, one cell (`one_cell`) is cheaper than a grid


@dataclass(frozen=True)
class Grid:
    """Cells of side ``cell`` from (x0, y0), nx by ny; the things of cell (ix, iy) are
    ``items[start[iy * nx + ix]:start[iy * nx + ix + 1]]`` in increasing order."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    start: I64
    items: I64
    count: int = 0  # things indexed (0..count-1)
    _scratch: dict[str, np.ndarray] = field(default_factory=dict, compare=False, repr=False)

    def params(self) -> F64:
        """(x0, y0, cell, nx, ny) as floats, as the compiled loops take them."""
        return np.array([self.x0, self.y0, self.cell, self.nx, self.ny], dtype=np.float64)

    def near(self, x: float, y: float, reach: float) -> I64:
        """The things listed in the cells that the square of half side ``reach`` about (x, y)
        overlaps, in increasing order (candidates: the caller tests them)."""
        sc = self._scratch
        if not sc:
            sc["mark"] = np.full(self.count, -1, np.int64)
            sc["out"] = np.empty(self.count, np.int64)
            sc["stamp"] = np.zeros(1, np.int64)
        sc["stamp"][0] += 1
        m = near_disc(x, y, reach, self.params(), self.start, self.items, sc["mark"],
                      int(sc["stamp"][0]), sc["out"])
        return np.sort(sc["out"][:m])


def layout(x_lo: float, y_lo: float, x_hi: float, y_hi: float, count: int,
           typical_radius: float) -> tuple[float, float, float, int, int]:
    """Origin, cell side and cell counts of a grid over the box for ``count`` things: cells
    about the size that holds one thing each on average, never smaller than a thing's disc
    (nor `MIN_CELL`), and never more than `MAX_CELLS_PER_THING` per thing (plus 64)."""
    w = max(x_hi - x_lo, 1e-3)
    h = max(y_hi - y_lo, 1e-3)
    cell = max(math.sqrt(w * h / max(count, 1)), 2.0 * typical_radius, MIN_CELL)
    budget = MAX_CELLS_PER_THING * count + 64
    while math.ceil(w / cell) * math.ceil(h / cell) > budget:
        cell *= 1.25
    nx = max(1, math.ceil(w / cell))
    ny = max(1, math.ceil(h / cell))
    return x_lo, y_lo, cell, nx, ny


def build(cx: F64, cy: F64, radius: F64, bounds: tuple[float, float, float, float],
          typical_radius: float | None = None) -> Grid:
    """The grid of discs (cx, cy, radius) over ``bounds`` (x_lo, y_lo, x_hi, y_hi), grown to
    hold every finite disc; discs with a non-finite centre are left out."""
    x_lo, y_lo, x_hi, y_hi = bounds
    fin = np.isfinite(cx) & np.isfinite(cy) & np.isfinite(radius)
    if fin.any():
        r = radius[fin]
        x_lo = min(x_lo, float((cx[fin] - r).min()))
        y_lo = min(y_lo, float((cy[fin] - r).min()))
        x_hi = max(x_hi, float((cx[fin] + r).max()))
        y_hi = max(y_hi, float((cy[fin] + r).max()))
    if typical_radius is None:
        typical_radius = float(np.median(radius[fin])) if fin.any() else 0.0
    x0, y0, cell, nx, ny = layout(x_lo - PAD, y_lo - PAD, x_hi + PAD, y_hi + PAD,
                                  int(cx.shape[0]), typical_radius)
    start, items = _fill(np.ascontiguousarray(cx, dtype=np.float64),
                         np.ascontiguousarray(cy, dtype=np.float64),
                         np.ascontiguousarray(radius, dtype=np.float64), x0, y0, cell, nx, ny)
    return Grid(x0, y0, cell, nx, ny, start, items, int(cx.shape[0]))


def one_cell(count: int) -> Grid:
    """A grid of one cell listing every thing wherever it is: for a few things, where
    walking cells costs more than looking at them all."""
    return Grid(0.0, 0.0, math.inf, 1, 1, np.array([0, count], dtype=np.int64),
                np.arange(count, dtype=np.int64), count)


@njit(cache=True)
def cell_of(v: float, origin: float, cell: float, n: int) -> int:
    """The index of the cell holding coordinate v, clamped to 0..n-1."""
    q = (v - origin) / cell
    if not q >= 0.0:  # also nan
        return 0
    if q >= n - 1.0:
        return n - 1
    return math.floor(q)


@njit(cache=True)
def _span(lo: float, hi: float, origin: float, cell: float, n: int) -> tuple[int, int]:
    return cell_of(lo - PAD, origin, cell, n), cell_of(hi + PAD, origin, cell, n)


@njit(cache=True)
def _cells_of(x: float, y: float, r: float, x0: float, y0: float, cell: float, nx: int,
              ny: int) -> tuple[int, int, int, int]:
    """The first and last column and row of the cells a thing at (x, y) of radius r touches;
    an empty range (0, -1) for a thing with no finite place."""
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(r)):
        return 0, -1, 0, -1
    ax, bx = _span(x - r, x + r, x0, cell, nx)
    ay, by = _span(y - r, y + r, y0, cell, ny)
    return ax, bx, ay, by


@njit(cache=True)
def _fill(cx: np.ndarray, cy: np.ndarray, radius: np.ndarray, x0: float, y0: float,
          cell: float, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    k = cx.shape[0]
    count = np.zeros(nx * ny + 1, np.int64)
    for f in range(k):
        ax, bx, ay, by = _cells_of(cx[f], cy[f], radius[f], x0, y0, cell, nx, ny)
        for iy in range(ay, by + 1):
            for ix in range(ax, bx + 1):
                count[iy * nx + ix + 1] += 1
    start = np.cumsum(count)
    fill = start[:-1].copy()
    items = np.empty(start[-1], np.int64)
    for f in range(k):
        ax, bx, ay, by = _cells_of(cx[f], cy[f], radius[f], x0, y0, cell, nx, ny)
        for iy in range(ay, by + 1):
            for ix in range(ax, bx + 1):
                c = iy * nx + ix
                items[fill[c]] = f
                fill[c] += 1
    return start, items


@njit(cache=True)
def near_disc(x: float, y: float, reach: float, gp: np.ndarray, start: np.ndarray,
              items: np.ndarray, mark: np.ndarray, stamp: int, out: np.ndarray) -> int:
    """Write into ``out`` each thing listed in a cell that the square of half side ``reach``
    about (x, y) overlaps, once (``mark`` holds the last stamp each thing was written under;
    pass a fresh stamp per query); returns how many. Candidates only: the caller tests them."""
    nx = int(gp[3])
    ny = int(gp[4])
    ax, bx = _span(x - reach, x + reach, gp[0], gp[2], nx)
    ay, by = _span(y - reach, y + reach, gp[1], gp[2], ny)
    n = 0
    for iy in range(ay, by + 1):
        for ix in range(ax, bx + 1):
            c = iy * nx + ix
            for j in range(start[c], start[c + 1]):
                f = items[j]
                if mark[f] != stamp:
                    mark[f] = stamp
                    out[n] = f
                    n += 1
    return n
