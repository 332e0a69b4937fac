"""Plane polygons: checks, convex pieces (ear clipping then merging) and hulls."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from worlds.polygon import (
    convex_hull,
    convex_pieces,
    is_axis_rectangle,
    problem,
    signed_area,
    triangulate,
)

L_SHAPE = ((0.0, 0.0), (2.0, 0.0), (2.0, 0.5), (0.5, 0.5), (0.5, 2.0), (0.0, 2.0))


def inside(p: tuple[float, float], poly: tuple[tuple[float, float], ...]) -> bool:
    """Even-odd rule (a point on an edge may go either way)."""
    x, y = p
    hit = False
    n = len(poly)
    for i in range(n):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % n]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit


def is_convex_anticlockwise(poly: tuple[tuple[float, float], ...]) -> bool:
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = poly[i - 1], poly[i], poly[(i + 1) % n]
        if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) < -1e-12:
            return False
    return signed_area(poly) > 0


def test_problems_are_named() -> None:
    assert problem([(0, 0), (1, 0)]) == "2 points"
    assert problem([(0, 0), (1, 0), (2, 0)]) == "zero area"
    assert problem([(0, 0), (1, 1), (1, 0), (0, 1)]) == "edges 0 and 2 cross"
    assert problem([(0, 0), (1, 0), (1, 0), (0, 1)]) == "point 2 repeats point 1"
    assert problem([(0, 0), (2, 0), (1, 0), (1, 1)]) == "edges meeting at point 1 fold back"
    assert problem(L_SHAPE) is None
    assert problem(L_SHAPE[::-1]) is None


def test_l_shape_splits_into_two_convex_pieces() -> None:
    pieces = convex_pieces(L_SHAPE)
    assert len(pieces) == 2
    assert all(is_convex_anticlockwise(p) for p in pieces)
    assert sum(signed_area(p) for p in pieces) == pytest.approx(signed_area(L_SHAPE))
    # clockwise input gives the same tiling area
    assert sum(signed_area(p) for p in convex_pieces(L_SHAPE[::-1])) == pytest.approx(1.75)


def test_convex_polygon_is_its_own_piece_and_triangles_cover_it() -> None:
    tri = ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    assert convex_pieces(tri) == (tri,)
    assert convex_pieces(tri[::-1]) == (tri,)
    idx = triangulate(L_SHAPE)
    assert len(idx) == 4
    assert sum(signed_area([L_SHAPE[i] for i in t]) for t in idx) == pytest.approx(1.75)


def test_hull_and_axis_rectangles() -> None:
    assert convex_hull((*L_SHAPE, (1.0, 1.0))) == ((0.0, 0.0), (2.0, 0.0), (2.0, 0.5),
                                                     (0.5, 2.0), (0.0, 2.0))
    assert is_axis_rectangle(((-0.2, -0.19), (0.2, -0.19), (0.2, 0.19), (-0.2, 0.19)))
    assert not is_axis_rectangle(((0, 0), (1, 1), (1, 0), (0, 1)))  # crossed
    assert not is_axis_rectangle(((0, 0), (1, 0), (1, 1)))
    assert not is_axis_rectangle(((0, 0), (2, 1), (1, 3), (-1, 2)))  # turned


@st.composite
def star_polygons(draw: st.DrawFn) -> tuple[tuple[float, float], ...]:
    """Simple polygons: vertices at increasing angles round the origin, random radii."""
    n = draw(st.integers(3, 12))
    gaps = draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n))
    radii = draw(st.lists(st.floats(0.2, 3.0), min_size=n, max_size=n))
    total = sum(gaps)
    out, a = [], 0.0
    for g, r in zip(gaps, radii, strict=True):
        out.append((r * math.cos(a), r * math.sin(a)))
        a += g / total * 2 * math.pi * 0.999
    return tuple(out)


@settings(max_examples=150, deadline=None)
@given(star_polygons(), st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), max_size=30))
def test_pieces_tile_random_polygons(poly: tuple[tuple[float, float], ...],
                                     probes: list[tuple[float, float]]) -> None:
    if problem(poly) is not None:
        return
    pieces = convex_pieces(poly)
    assert all(is_convex_anticlockwise(p) for p in pieces)
    assert sum(signed_area(p) for p in pieces) == pytest.approx(abs(signed_area(poly)),
                                                                rel=1e-9, abs=1e-12)
    assert len(pieces) <= len(poly) - 2
    for p in probes:
        n_in = sum(inside(p, q) for q in pieces)
        assert n_in <= 1 or not inside(p, poly)  # pieces overlap nowhere inside
        if inside(p, poly) and n_in == 0:  # only a probe on a shared edge may miss all
            assert any(_near_edge(p, q) for q in pieces)


def _near_edge(p: tuple[float, float], poly: tuple[tuple[float, float], ...]) -> bool:
    n = len(poly)
    for i in range(n):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % n]
        dx, dy = x1 - x0, y1 - y0
        t = max(0.0, min(1.0, ((p[0] - x0) * dx + (p[1] - y0) * dy) / (dx * dx + dy * dy)))
        if math.hypot(x0 + t * dx - p[0], y0 + t * dy - p[1]) < 1e-9:
            return True
    return False


def test_prism_mesh_is_closed_and_wound_outwards() -> None:
    from collections import Counter

    from worlds.polygon import prism_mesh

    verts, tris = prism_mesh(L_SHAPE[::-1], 0.2, 0.7)
    faces = [tuple(tris[i:i + 3]) for i in range(0, len(tris), 3)]
    edges = Counter((f[k], f[(k + 1) % 3]) for f in faces for k in range(3))
    assert all(edges[(b, a)] == 1 for (a, b) in edges) and set(edges.values()) == {1}
    volume = 0.0  # the divergence theorem: positive only when every face looks outwards
    for a, b, c in faces:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = verts[a], verts[b], verts[c]
        volume += (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx)
                   + az * (bx * cy - by * cx)) / 6.0
    assert volume == pytest.approx(1.75 * 0.5)


def test_distance_to_a_polygon() -> None:
    from worlds.polygon import distance

    assert distance((1.0, 0.8), L_SHAPE) == pytest.approx(0.3)  # in the notch
    assert distance((2.3, 0.9), L_SHAPE) == pytest.approx(0.5)  # off a corner
    assert distance((0.25, 1.0), L_SHAPE) == 0.0  # inside
    assert distance((-1.0, 1.0), L_SHAPE) == pytest.approx(1.0)
    assert distance((3.0, 0.25), L_SHAPE) == pytest.approx(1.0)
