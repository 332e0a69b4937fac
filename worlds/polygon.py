"""Plane polygons (pure): checking, convex pieces and hulls.

A polygon is a sequence of (x, y) vertices in order, either way round, without repeating the
first. `problem` says what makes one unusable (fewer than 3 points, zero area, edges that
cross); `convex_pieces` splits a simple polygon, convex or not, into convex polygons
(anticlockwise) that tile it: ear-clipping triangles, then neighbours merged across their
shared diagonal while the union stays convex (Hertel-Mehlhorn). `convex_hull` is the smallest
convex polygon holding a set of points (Andrew's monotone chain); `prism_mesh` the triangles
of a polygon raised between two heights; `distance` how far a point lies from a polygon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Point = tuple[float, float]
Polygon = tuple[Point, ...]

#: relative to the polygon's size squared: a cross product this small counts as zero
_EPS = 1e-12


def signed_area(pts: Sequence[Point]) -> float:
    """Positive for an anticlockwise polygon (shoelace formula)."""
    s = 0.0
    n = len(pts)
    for i in range(n):
        x0, y0 = pts[i]
        x1, y1 = pts[(i + 1) % n]
        s += x0 * y1 - x1 * y0
    return s / 2.0


def _cross(o: Point, a: Point, b: Point) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _scale2(pts: Sequence[Point]) -> float:
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    return max(max(xs) - min(xs), max(ys) - min(ys), 1e-300) ** 2


def _segments_cross(a: Point, b: Point, c: Point, d: Point, eps: float) -> bool:
    """Do segments ab and cd share a point (touching counts)?"""
    d1, d2 = _cross(c, d, a), _cross(c, d, b)
    d3, d4 = _cross(a, b, c), _cross(a, b, d)
    if ((d1 > eps and d2 < -eps) or (d1 < -eps and d2 > eps)) and \
            ((d3 > eps and d4 < -eps) or (d3 < -eps and d4 > eps)):
        return True

    def on(p: Point, q: Point, r: Point, side: float) -> bool:  # r on segment pq
        return abs(side) <= eps and min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and \
            min(p[1], q[1]) <= r[1] <= max(p[1], q[1])

    return on(c, d, a, d1) or on(c, d, b, d2) or on(a, b, c, d3) or on(a, b, d, d4)


def problem(pts: Sequence[Point]) -> str | None:
    """What makes `pts` no simple polygon, in a few words, or None when it is one."""
    n = len(pts)
    if n < 3:
        return f"{n} point{'s' if n != 1 else ''}"
    eps = _EPS * _scale2(pts)
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        if a == b:
            return f"point {(i + 1) % n} repeats point {i}"
    if all(abs(_cross(pts[0], pts[1], p)) <= eps for p in pts[2:]):
        return "zero area"
    for i in range(n):
        a, b, c = pts[i - 1], pts[i], pts[(i + 1) % n]
        if abs(_cross(a, b, c)) <= eps and \
                (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]) < 0:
            return f"edges meeting at point {i} fold back"
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # neighbours share a vertex
            if _segments_cross(a, b, pts[j], pts[(j + 1) % n], eps):
                return f"edges {i} and {j} cross"
    if abs(signed_area(pts)) <= eps:
        return "zero area"
    return None


def _anticlockwise(pts: Sequence[Point]) -> list[Point]:
    """The polygon anticlockwise, without vertices on a straight line between neighbours."""
    out = [(float(x), float(y)) for x, y in pts]
    if signed_area(out) < 0:
        out.reverse()
    eps = _EPS * _scale2(out)
    changed = True
    while changed and len(out) > 3:
        changed = False
        for i in range(len(out)):
            if abs(_cross(out[i - 1], out[i], out[(i + 1) % len(out)])) <= eps:
                del out[i]
                changed = True
                break
    return out


def triangulate(pts: Sequence[Point]) -> list[tuple[int, int, int]]:
    """Ear clipping of a simple anticlockwise polygon: index triples, each anticlockwise."""
    n = len(pts)
    eps = _EPS * _scale2(pts)
    left = list(range(n))
    out: list[tuple[int, int, int]] = []
    while len(left) > 3:
        m = len(left)
        for k in range(m):
            i, j, h = left[k - 1], left[k], left[(k + 1) % m]
            a, b, c = pts[i], pts[j], pts[h]
            if _cross(a, b, c) <= eps:
                continue  # a reflex (or flat) corner is no ear
            if any(_inside_or_on(pts[q], a, b, c, eps) for q in left if q not in (i, j, h)):
                continue
            out.append((i, j, h))
            del left[k]
            break
        else:  # numerically stuck (a nearly flat remainder): fan out what is left
            out.extend((left[0], left[q], left[q + 1]) for q in range(1, len(left) - 1))
            return out
    out.append((left[0], left[1], left[2]))
    return out


def _inside_or_on(p: Point, a: Point, b: Point, c: Point, eps: float) -> bool:
    return _cross(a, b, p) >= -eps and _cross(b, c, p) >= -eps and _cross(c, a, p) >= -eps


def _convex(pts: Sequence[Point], eps: float) -> bool:
    n = len(pts)
    return all(_cross(pts[i - 1], pts[i], pts[(i + 1) % n]) >= -eps for i in range(n))


def is_convex(pts: Sequence[Point]) -> bool:
    """A simple polygon with no reflex corner (either way round)."""
    if problem(pts) is not None:
        return False
    poly = _anticlockwise(pts)
    return _convex(poly, _EPS * _scale2(poly))


def convex_pieces(pts: Sequence[Point]) -> tuple[Polygon, ...]:
    """Anticlockwise convex polygons tiling the simple polygon `pts` (itself when convex)."""
    poly = _anticlockwise(pts)
    eps = _EPS * _scale2(poly)
    if _convex(poly, eps):
        return (tuple(poly),)
    pieces: list[list[int]] = [list(t) for t in triangulate(poly)]
    merged = True
    while merged:
        merged = False
        for a in range(len(pieces)):
            for b in range(a + 1, len(pieces)):
                joined = _join(pieces[a], pieces[b])
                if joined is not None and _convex([poly[i] for i in joined], eps):
                    pieces[a] = joined
                    del pieces[b]
                    merged = True
                    break
            if merged:
                break
    return tuple(tuple(poly[i] for i in p) for p in pieces)


def _join(p: list[int], q: list[int]) -> list[int] | None:
    """The union of two anticlockwise index polygons sharing an edge (i -> j in p, j -> i
    in q), or None when they share none."""
    n, m = len(p), len(q)
    for s in range(n):
        i, j = p[s], p[(s + 1) % n]
        for t in range(m):
            if q[t] == j and q[(t + 1) % m] == i:
                # p from j round to i, then q's vertices after i up to before j
                out = [p[(s + 1 + k) % n] for k in range(n)]
                out += [q[(t + 2 + k) % m] for k in range(m - 2)]
                return out
    return None


def convex_hull(pts: Sequence[Point]) -> Polygon:
    """The convex hull, anticlockwise, without collinear vertices (Andrew's monotone chain)."""
    ps = sorted({(float(x), float(y)) for x, y in pts})
    if len(ps) < 3:
        return tuple(ps)

    def half(seq: list[Point]) -> list[Point]:
        out: list[Point] = []
        for p in seq:
            while len(out) >= 2 and _cross(out[-2], out[-1], p) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = half(ps), half(ps[::-1])
    return tuple(lower[:-1] + upper[:-1])


def is_axis_rectangle(pts: Sequence[Point]) -> bool:
    """Four corners of a rectangle whose sides are parallel to the axes (either way round)."""
    if len(pts) != 4:
        return False
    xs = sorted({p[0] for p in pts})
    ys = sorted({p[1] for p in pts})
    if len(xs) != 2 or len(ys) != 2 or len(set(pts)) != 4:
        return False
    # consecutive corners differ in exactly one coordinate
    return all((pts[i][0] == pts[i - 1][0]) != (pts[i][1] == pts[i - 1][1]) for i in range(4))


def prism_mesh(pts: Sequence[Point], bottom: float, top: float
               ) -> tuple[list[tuple[float, float, float]], list[int]]:
    """The simple polygon `pts` raised from `bottom` to `top`: vertices (the bottom ring,
    then the top one, anticlockwise) and the triangles of its faces as index triples, each
    wound anticlockwise seen from outside (caps by ear clipping, so non-convex works)."""
    poly = _anticlockwise(pts)
    m = len(poly)
    verts = [(x, y, bottom) for x, y in poly] + [(x, y, top) for x, y in poly]
    tris: list[int] = []
    for a, b, c in triangulate(poly):
        tris += [a, c, b]  # the bottom, seen from below
        tris += [m + a, m + b, m + c]  # the top
    for k in range(m):
        j = (k + 1) % m
        tris += [k, j, m + j, k, m + j, m + k]
    return verts, tris


def distance(p: Point, pts: Sequence[Point]) -> float:
    """Metres from `p` to the polygon `pts` (0 inside it or on its edge)."""
    x, y = p
    best = math.inf
    inside = False
    n = len(pts)
    for i in range(n):
        (x0, y0), (x1, y1) = pts[i], pts[(i + 1) % n]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
        dx, dy = x1 - x0, y1 - y0
        t = ((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy)
        t = min(1.0, max(0.0, t))
        best = min(best, math.hypot(x0 + t * dx - x, y0 + t * dy - y))
    return 0.0 if inside else best
