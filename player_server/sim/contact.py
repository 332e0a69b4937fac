"""Whether a robot touches a charging model: two rectangles on the floor (pure).

A rectangle is (centre x, centre y, half length, half width, yaw). The robot's body (its
size box) touches a model's footprint when it overlaps that footprint grown by `MARGIN_M` on
every side; tested by separating axes (two rectangles are apart exactly when, along one of
their four edge directions, their projections do not overlap).
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
