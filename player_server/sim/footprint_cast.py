"""A culling 2-D ray caster over whole footprints (pure numpy), and the footprint types.

The simulation casts with the compiled loop of ``cast_kernel``, which takes the same
footprints and agrees with this caster to float64 noise (tested); this one is its vectorised
reference.

Footprints are oriented rectangles, circles and convex polygons, each with the height of its
top (a polygon also with that of its bottom), inside an optional rectangular room centred on
the origin whose walls face inwards. Planar points and directions are complex numbers. A cast
runs in three stages, each a handful of numpy calls however many rays and footprints there
are:

1. the room: where each ray leaves the room's rectangle, in closed form per ray;
2. culling: one matrix product gives, for every (footprint, ray) pair, how far the
   footprint's centre lies behind the ray origin and beside the ray; a pair is a candidate
   when its bounding circle touches the ray's half-line;
3. the candidates only: a slab test per rectangle (a ray that starts inside a rectangle
   leaves it unseen, as a sensor inside its own body must), a quadratic per circle, the
   half planes of every edge per polygon (Cyrus-Beck), then the nearest hit per ray
   (``np.minimum.at``).

It agrees with the face caster of ``raycast`` (the reference in the tests) to that caster's
float32 noise, and with brute-force float64 geometry to 1e-9 m. Its cost grows with
rays x footprints only through the product and four elementwise passes; pairs whose ray
starts inside the footprint (a sensor in its own body, when the caller names it) are dropped
before the exact tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
C128 = NDArray[np.complex128]
I64 = NDArray[np.int64]

# OpenBLAS runs a product on several threads above m*n*k = 4 * 65536 (here 8 * rays *
# footprints); its worker threads then spin and starve the elementwise work that follows on a
# busy machine. Rays are cast in chunks that keep each product (and the culling arrays) small.
_CHUNK_ELEMENTS = 30_000


@dataclass(frozen=True)
class Room:
    """The arena: walls at x = +-half_x and y = +-half_y facing inwards, of height top."""

    half_x: float
    half_y: float
    top: float


def _no_polygons() -> I64:
    return np.zeros(1, dtype=np.int64)


@dataclass(frozen=True)
class Footprints:
    """n_rect rectangles, then n_poly convex polygons, then circles.

    centre: complex centres (all; a polygon's is any point its bounding circle is centred
    on); head_conj: exp(-i yaw) of each rectangle; half: complex half extents hx + i hy of
    each rectangle; radius: bounding radius (all; the radius of a circle); top: height of
    each top (all). Polygon p has the anticlockwise world vertices
    poly_vert[poly_start[p]:poly_start[p + 1]] and stands from poly_bottom[p] (rectangles and
    circles stand on the floor).
    """

    centre: C128
    head_conj: C128
    half: C128
    radius: F64
    top: F64
    poly_start: I64 = field(default_factory=_no_polygons)
    poly_vert: C128 = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    poly_bottom: F64 = field(default_factory=lambda: np.zeros(0, dtype=np.float64))
    _cull: dict[str, F64] = field(default_factory=dict, compare=False, repr=False)

    @property
    def n_poly(self) -> int:
        return int(self.poly_start.shape[0]) - 1

    def poly_edges(self) -> tuple[C128, C128]:
        """(n_poly, most vertices) start points and outward normals of every polygon's
        edges, padded with edges of no length (computed once per Footprints)."""
        got = self._cull.get("edges")
        if got is None:
            start, vert = self.poly_start, self.poly_vert
            sizes = np.diff(start)
            m = int(sizes.max()) if sizes.size else 0
            a = np.zeros((sizes.size, m), dtype=np.complex128)
            nrm = np.zeros((sizes.size, m), dtype=np.complex128)
            for p in range(sizes.size):
                v = vert[start[p]:start[p + 1]]
                k = v.size
                a[p, :k] = v
                a[p, k:] = v[-1]
                nrm[p, :k] = -1j * (np.roll(v, -1) - v)  # the edge turned clockwise: outwards
            got = np.stack([a, nrm])
            self._cull["edges"] = got
        return got[0], got[1]

    def cull_weights(self) -> F64:
        """(2 count, 4) weights of the culling product (computed once per Footprints)."""
        w = self._cull.get("w")
        if w is None:
            k = self.count
            cf = self.centre.view(np.float64).reshape(-1, 2)
            w = np.empty((2 * k, 4))
            np.negative(cf, out=w[:k, :2])  # behind: -(c.d) + o.d
            np.multiply(cf[:, ::-1], (-1.0, 1.0), out=w[k:, :2])  # beside: c x d - o x d
            w[:k, 2:] = (1.0, 0.0)
            w[k:, 2:] = (0.0, 1.0)
            self._cull["w"] = w
        return w

    @property
    def n_rect(self) -> int:
        return int(self.head_conj.shape[0])

    @property
    def count(self) -> int:
        return int(self.centre.shape[0])

    @staticmethod
    def build(rect_centre: C128, rect_yaw_head: C128, rect_half_x: F64, rect_half_y: F64,
              rect_top: F64, circle_centre: C128, circle_radius: F64,
              circle_top: F64) -> Footprints:
        """From rectangles (centre, heading exp(i yaw), half extents, top) and circles."""
        return Footprints(
            centre=np.concatenate([rect_centre, circle_centre]),
            head_conj=np.conjugate(rect_yaw_head),
            half=rect_half_x + 1j * rect_half_y,
            radius=np.concatenate([np.hypot(rect_half_x, rect_half_y), circle_radius]),
            top=np.concatenate([rect_top, circle_top]),
        )

    def with_polygons(self, polygons: Polygons) -> Footprints:
        """These footprints (without polygons) with the convex polygons after the
        rectangles."""
        if polygons.count == 0:
            return self
        k = self.n_rect
        return Footprints(
            centre=np.concatenate([self.centre[:k], polygons.centre, self.centre[k:]]),
            head_conj=self.head_conj, half=self.half,
            radius=np.concatenate([self.radius[:k], polygons.radius, self.radius[k:]]),
            top=np.concatenate([self.top[:k], polygons.top, self.top[k:]]),
            poly_start=polygons.start, poly_vert=polygons.vert, poly_bottom=polygons.bottom)


@dataclass(frozen=True)
class Polygons:
    """Convex polygons standing still: world vertices anticlockwise, polygon p's from
    vert[start[p]] to vert[start[p + 1] - 1]; the centre and radius of a circle holding
    each; the heights of each bottom and top."""

    start: I64
    vert: C128
    centre: C128
    radius: F64
    bottom: F64
    top: F64

    @property
    def count(self) -> int:
        return int(self.start.shape[0]) - 1

    @staticmethod
    def build(polygons: list[tuple[list[complex], float, float]]) -> Polygons:
        """From (anticlockwise convex vertices, bottom, top) of each polygon."""
        sizes = [len(v) for v, _, _ in polygons]
        start = np.zeros(len(polygons) + 1, dtype=np.int64)
        start[1:] = np.cumsum(sizes, dtype=np.int64)
        vert = np.array([z for v, _, _ in polygons for z in v], dtype=np.complex128)
        centre = np.array([(min(z.real for z in v) + max(z.real for z in v)) / 2
                           + 1j * (min(z.imag for z in v) + max(z.imag for z in v)) / 2
                           for v, _, _ in polygons], dtype=np.complex128)
        radius = np.array([max(abs(z - c) for z in v) for (v, _, _), c in
                           zip(polygons, centre, strict=True)], dtype=np.float64)
        return Polygons(start, vert, centre, radius,
                        np.array([b for _, b, _ in polygons], dtype=np.float64),
                        np.array([t for _, _, t in polygons], dtype=np.float64))


def room_exit(o: C128, d: C128, room: Room) -> F64:
    """Distance along each unit ray (origin o, direction d) to the room's walls (inf where a
    ray starting outside the room never meets a wall's inner face)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return _room_exit(np.ascontiguousarray(o), np.ascontiguousarray(d), room)


def _room_exit(o: C128, d: C128, room: Room) -> F64:
    ov = o.view(np.float64).reshape(-1, 2)
    dv = d.view(np.float64).reshape(-1, 2)
    t = np.copysign((room.half_x, room.half_y), dv)  # the wall ahead on each axis
    t -= ov
    t /= dv
    out = np.fmin(t[:, 0], t[:, 1])
    if out.size and not out.min() >= 0.0:  # an origin outside the room (or nan): no wall
        out[~(out >= 0.0)] = np.inf
    return out


class FootprintCaster:
    """Casts batches of rays against Footprints and a Room (owns no state between calls)."""

    def cast(self, o: C128, d: C128, limit: F64, z: F64, fp: Footprints,
             room: Room | None, own: I64 | None = None) -> F64:
        """Distance along each unit ray (origin o, direction d, height z) to the nearest
        footprint (or wall) at least as tall as z, or ``limit`` when nothing is nearer.

        own (optional, per ray): a footprint the ray starts inside (its sensor's own body),
        or -1. It cannot be hit anyway; naming it spares its pair the exact test.
        """
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return self._cast(np.ascontiguousarray(o), np.ascontiguousarray(d), limit, z, fp,
                              room, own)

    def _cast(self, o: C128, d: C128, limit: F64, z: F64, fp: Footprints,
              room: Room | None, own: I64 | None) -> F64:
        best = np.array(limit, dtype=np.float64, copy=True)
        n = best.shape[0]
        if n == 0:
            return best
        if room is not None:
            walls = _room_exit(o, d, room)
            if float(z.max()) > room.top:
                walls[z > room.top] = np.inf
            np.minimum(best, walls, out=best)
        k = fp.count
        if k == 0:
            return best
        # Per-ray features [dx, dy, o.d, -(o x d)] (the last two: o conj(d)) and
        # per-footprint weights give, per pair, how far the centre lies behind the origin,
        # -(c - o).d, and beside the ray, (c - o) x d. A candidate's bounding circle touches
        # the ray's half-line.
        feat = np.empty((4, n))
        feat[:2] = d.view(np.float64).reshape(-1, 2).T
        feat[2:] = (o * np.conjugate(d)).view(np.float64).reshape(-1, 2).T
        w = fp.cull_weights()
        radius = fp.radius[:, None]
        chunk = max(1, _CHUNK_ELEMENTS // k)
        n_rect = fp.n_rect
        # Candidate pairs per chunk: (footprint, ray, v) with v = (c - o) conj(d), i.e.
        # along the ray + i (o - c) x d; rectangles', polygons' and circles' pairs apart.
        rects: list[tuple[I64, I64, C128]] = []
        circles: list[tuple[I64, I64, C128]] = []
        polys: list[tuple[I64, I64, C128]] = []
        first_circle = n_rect + fp.n_poly
        for start in range(0, n, chunk):
            stop = min(n, start + chunk)
            m = np.matmul(w, feat[:, start:stop])
            test = np.abs(m[k:])
            np.maximum(test, m[:k], out=test)
            cand = test <= radius
            if own is not None:
                sub = own[start:stop]
                j = np.flatnonzero(sub >= 0)
                cand.ravel()[sub[j] * (stop - start) + j] = False
            flat = np.flatnonzero(cand)  # sorted: rectangles' pairs come first
            if flat.size == 0:
                continue
            mf = m.ravel()
            fi, ri = np.divmod(flat, stop - start)
            if start:
                ri += start
            v = np.empty(flat.shape[0], dtype=np.complex128)
            np.negative(mf[flat], out=v.real)
            flat += k * (stop - start)
            np.negative(mf[flat], out=v.imag)
            split = int(np.searchsorted(fi, n_rect))
            if split:
                rects.append((fi[:split], ri[:split], v[:split]))
            csplit = int(np.searchsorted(fi, first_circle))
            if split < csplit:
                polys.append((fi[split:csplit], ri[split:csplit], v[split:csplit]))
            if csplit < fi.shape[0]:
                circles.append((fi[csplit:], ri[csplit:], v[csplit:]))
        low = bool(fp.top.min() < z.max())  # footprints lower than a ray pass under it
        for kind, parts in (("rect", rects), ("circle", circles), ("poly", polys)):
            if not parts:
                continue
            if len(parts) == 1:
                fi, ri, v = parts[0]
            else:
                fi, ri, v = (np.concatenate([p[j] for p in parts]) for j in range(3))
            if kind == "rect":
                dist = _rect_hits(d, fp, fi, ri, v)
            elif kind == "circle":
                dist = _circle_hits(fp, fi, v)
            else:
                dist = _poly_hits(o, d, fp, fi - n_rect, ri)
                dist[fp.poly_bottom[fi - n_rect] > z[ri]] = np.inf
            if low:
                dist[fp.top[fi] < z[ri]] = np.inf
            np.minimum.at(best, ri, dist)
        return best


def _rect_hits(d: C128, fp: Footprints, fi: I64, ri: I64, v: C128) -> F64:
    """Slab test: entry distance of each ray into its rectangle; inf for a miss or for a ray
    that starts inside (or past) it. v is the centre relative to the ray (as in the cull)."""
    q = d[ri]
    q *= fp.head_conj[fi]  # the direction in the rectangle's frame
    p = v * q  # minus the origin in the rectangle's frame: v = (c - o) conj(d)
    qv = q.view(np.float64).reshape(-1, 2)
    qv += np.copysign(1e-30, qv)  # a ray parallel to a side: a huge finite slab time
    inv = np.reciprocal(qv)
    a = p.view(np.float64).reshape(-1, 2)
    a *= inv  # per axis: the slab is crossed between a - b and a + b
    b = np.abs(inv)
    b *= fp.half[fi].view(np.float64).reshape(-1, 2)
    lo = a - b
    a += b
    t_near = np.maximum(lo[:, 0], lo[:, 1])
    ok = t_near <= np.minimum(a[:, 0], a[:, 1])
    ok &= t_near > 0.0
    return np.where(ok, t_near, np.inf)


def _circle_hits(fp: Footprints, fi: I64, v: C128) -> F64:
    """Distance to the near intersection with each circle; inf for a ray that starts inside
    (or past) it. v is the centre relative to the ray; candidates pass beside within r."""
    r = fp.radius[fi]
    disc = r * r
    disc -= v.imag * v.imag
    np.maximum(disc, 0.0, out=disc)
    t = v.real - np.sqrt(disc)
    return np.where(t > 0.0, t, np.inf)


def _poly_hits(o: C128, d: C128, fp: Footprints, pi: I64, ri: I64) -> F64:
    """Entry distance of each ray into its convex polygon (clipped by every edge's half
    plane, Cyrus-Beck); inf for a miss or for a ray that starts inside (or past) it."""
    a, nrm = fp.poly_edges()
    a, nrm = a[pi], nrm[pi]  # (pairs, edges)
    rel = a - o[ri][:, None]
    num = rel.real * nrm.real + rel.imag * nrm.imag  # >= 0 where the origin is inside
    dd = d[ri][:, None]
    den = dd.real * nrm.real + dd.imag * nrm.imag  # < 0 where the ray goes in
    t = num / den
    t_in = np.max(np.where(den < 0.0, t, -np.inf), axis=1)
    t_out = np.min(np.where(den > 0.0, t, np.inf), axis=1)
    ok = (t_in <= t_out) & (t_in > 0.0)
    ok &= ~np.any((den == 0.0) & (num < 0.0), axis=1)  # beside an edge it runs along
    return np.where(ok, t_in, np.inf)
