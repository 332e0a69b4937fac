"""Whether a robot touches a charging model: two rectangles on the floor (pure).

A rectangle is (centre x, centre y, half length, half width, yaw). The robot's body (its
size box, or its outline polygon) touches a model's footprint when it overlaps that footprint
grown by `MARGIN_M` on every side; tested by separating axes (two convex polygons are apart
exactly when, along the normal of one of their edges, their projections do not overlap).
"""

from __future__ import annotations

import math

MARGIN_M = 0.05
"""How far apart a robot's body and a charging model may be and still be in contact (m)."""

Rect = tuple[float, float, float, float, float]


def _axes(yaw: float) -> tuple[tuple[float, float], tuple[float, float]]:
    c, s = math.cos(yaw), math.sin(yaw)
    return (c, s), (-s, c)


def rects_touch(a: Rect, b: Rect, margin: float = MARGIN_M) -> bool:
    """Does rectangle ``a`` overlap rectangle ``b`` grown by ``margin`` on every side?"""
    ax, ay, ahx, ahy, ayaw = a
    bx, by, bhx, bhy, byaw = b
    bhx, bhy = bhx + margin, bhy + margin
    (au, av), (bu, bv) = _axes(ayaw), _axes(byaw)
    dx, dy = bx - ax, by - ay
    for nx, ny in (au, av, bu, bv):
        ra = ahx * abs(au[0] * nx + au[1] * ny) + ahy * abs(av[0] * nx + av[1] * ny)
        rb = bhx * abs(bu[0] * nx + bu[1] * ny) + bhy * abs(bv[0] * nx + bv[1] * ny)
        if abs(dx * nx + dy * ny) > ra + rb:
            return False
    return True


def corners(r: Rect, margin: float = 0.0) -> list[tuple[float, float]]:
    """The rectangle's corners, anticlockwise, grown by `margin` on every side."""
    x, y, hx, hy, yaw = r
    (ux, uy), (vx, vy) = _axes(yaw)
    hx, hy = hx + margin, hy + margin
    return [(x + sx * hx * ux + sy * hy * vx, y + sx * hx * uy + sy * hy * vy)
            for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]


def polygon_touches(poly: list[tuple[float, float]], b: Rect, margin: float = MARGIN_M
                    ) -> bool:
    """Does the convex polygon ``poly`` overlap rectangle ``b`` grown by ``margin``?"""
    other = corners(b, margin)
    for shape in (poly, other):
        n = len(shape)
        for i in range(n):
            (x0, y0), (x1, y1) = shape[i], shape[(i + 1) % n]
            nx, ny = y1 - y0, x0 - x1
            pa = [nx * px + ny * py for px, py in poly]
            pb = [nx * px + ny * py for px, py in other]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True
