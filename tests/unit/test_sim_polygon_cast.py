"""Convex polygon footprints in both casters (compiled, with and without the grid, and numpy):
hand geometry, brute-force ray/segment geometry, non-convex polygons as convex pieces, heights
(bottom and top), rays from inside, and agreement with each other."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from player_server.sim.cast_kernel import CompiledCaster
from player_server.sim.footprint_cast import FootprintCaster, Footprints, Polygons, Room
from player_server.sim.raycast import Circles, Faces, RayCaster, arena_faces
from worlds.polygon import convex_pieces, problem

CASTERS = pytest.mark.parametrize("caster", [
    CompiledCaster, FootprintCaster, lambda: CompiledCaster(grid_min=0)],
    ids=["compiled", "numpy", "compiled-grid"])

L_SHAPE = ((0.0, 0.0), (2.0, 0.0), (2.0, 0.5), (0.5, 0.5), (0.5, 2.0), (0.0, 2.0))


def scene(polys: list[tuple[tuple[tuple[float, float], ...], float, float]],
          rects: np.ndarray | None = None, circles: np.ndarray | None = None) -> Footprints:
    """Polygons (vertices either way round, convex or not; bottom, top) after rectangles
    rows (cx, cy, yaw, hx, hy, top) and circles rows (cx, cy, r, top)."""
    r = np.zeros((0, 6)) if rects is None else rects.reshape(-1, 6)
    c = np.zeros((0, 4)) if circles is None else circles.reshape(-1, 4)
    fp = Footprints.build(r[:, 0] + 1j * r[:, 1], np.exp(1j * r[:, 2]), r[:, 3], r[:, 4],
                          r[:, 5], c[:, 0] + 1j * c[:, 1], c[:, 2], c[:, 3])
    pieces = [([complex(x, y) for x, y in piece], bottom, top)
              for pts, bottom, top in polys for piece in convex_pieces(pts)]
    return fp.with_polygons(Polygons.build(pieces))


def cast(caster: type, o: complex, angles: list[float] | np.ndarray, fp: Footprints,
         z: float = 0.2, limit: float = 10.0, room: Room | None = None) -> np.ndarray:
    a = np.asarray(angles, dtype=np.float64)
    n = a.size
    return caster().cast(np.full(n, o), np.exp(1j * a), np.full(n, limit), np.full(n, z),
                         fp, room)


@CASTERS
def test_triangle_and_l_shape_by_hand(caster: type) -> None:
    tri = ((1.0, -1.0), (3.0, 0.0), (1.0, 1.0))
    fp = scene([(tri, 0.0, 1.0)])
    r = cast(caster, 0j, [0.0, math.atan2(0.5, 2.0), math.pi], fp)
    assert r[0] == pytest.approx(1.0, abs=1e-12)
    # the ray at atan(1/4) meets the upper edge y = 1 - (x - 1)/2 of the triangle at x = 1
    assert r[1] == pytest.approx(math.hypot(1.0, 0.25), abs=1e-12)
    assert r[2] == 10.0
    # The L: a ray into its notch meets the inner corner's edges, not the bounding box.
    fp = scene([(L_SHAPE, 0.0, 1.0)])
    r = cast(caster, 1.5 + 1.5j, [math.pi, -math.pi / 2, -3 * math.pi / 4], fp)
    assert r == pytest.approx([1.0, 1.0, math.sqrt(2.0)], abs=1e-12)


@CASTERS
def test_heights_and_rays_from_inside(caster: type) -> None:
    tri = ((1.0, -1.0), (3.0, 0.0), (1.0, 1.0))
    fp = scene([(tri, 0.3, 0.6)])
    assert cast(caster, 0j, [0.0], fp, z=0.2)[0] == 10.0  # under it
    assert cast(caster, 0j, [0.0], fp, z=0.4)[0] == pytest.approx(1.0)
    assert cast(caster, 0j, [0.0], fp, z=0.7)[0] == 10.0  # over it
    fp = scene([(tri, 0.0, 1.0)])
    assert cast(caster, 1.5 + 0j, [0.0, math.pi], fp)[0] == 10.0  # from inside: unseen
    # Parallel to an edge, beside the polygon: a miss, and the room's wall ends the ray.
    square = scene([(((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)), 0.0, 1.0)])
    r = cast(caster, -1.0 + 1.5j, [0.0, -math.pi / 2], square, room=Room(3.0, 3.0, 1.0))
    assert r == pytest.approx([4.0, 4.5])
    assert cast(caster, 0.5 + 1.5j, [-math.pi / 2], square)[0] == pytest.approx(0.5)


def _brute(o: complex, a: float, polys: list[tuple[tuple[tuple[float, float], ...], float,
                                                    float]], z: float, limit: float) -> float:
    """Nearest crossing of any polygon's edge (polygons the ray starts inside, or whose
    height misses the ray, unseen), in float64."""
    dx, dy = math.cos(a), math.sin(a)
    best = limit
    for pts, bottom, top in polys:
        if not bottom <= z <= top or _inside(o, pts):
            continue
        for (x1, y1), (x2, y2) in zip(pts, pts[1:] + pts[:1], strict=True):
            ex, ey = x2 - x1, y2 - y1
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            t = ((x1 - o.real) * ey - (y1 - o.imag) * ex) / den
            u = ((x1 - o.real) * dy - (y1 - o.imag) * dx) / den
            if t > 0 and 0 <= u <= 1:
                best = min(best, t)
    return best


def _inside(p: complex, pts: tuple[tuple[float, float], ...]) -> bool:
    x, y = p.real, p.imag
    hit = False
    for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit


def _random_polygon(rng: np.random.Generator) -> tuple[tuple[float, float], ...]:
    """A star-shaped polygon round a random centre (convex or not), either way round."""
    n = int(rng.integers(3, 9))
    angles = np.sort(rng.uniform(0, 2 * math.pi, n))
    radii = rng.uniform(0.2, 1.2, n)
    c = rng.uniform(-3.5, 3.5, 2)
    pts = tuple((float(c[0] + r * math.cos(t)), float(c[1] + r * math.sin(t)))
                for r, t in zip(radii, angles, strict=True))
    return pts[::-1] if rng.random() < 0.5 else pts


@settings(max_examples=30, deadline=None)
@given(st.integers(min_value=0, max_value=2**31 - 1))
def test_casters_agree_with_brute_force_and_each_other(seed: int) -> None:
    rng = np.random.default_rng(seed)
    polys = []
    while len(polys) < int(rng.integers(1, 6)):
        pts = _random_polygon(rng)
        if problem(pts) is None:
            polys.append((pts, float(rng.choice([0.0, 0.3])), float(rng.choice([0.5, 1.0]))))
    rects = np.column_stack([rng.uniform(-4, 4, (3, 2)), rng.uniform(-3, 3, 3),
                             rng.uniform(0.05, 0.5, (3, 2)), np.full(3, 0.05)])  # low
    circles = np.array([[9.0, 9.0, 0.1, 0.05]])  # out of the way and low
    fp = scene(polys, rects, circles)
    n = 151
    o = rng.uniform(-4.5, 4.5, n) + 1j * rng.uniform(-4.5, 4.5, n)
    o[:50] = o[0]
    a = rng.uniform(-math.pi, math.pi, n)
    a[:8] = np.arange(8) * math.pi / 4
    d = np.exp(1j * a)
    z = rng.choice([0.1, 0.4, 0.8], n)
    limit = rng.uniform(0.5, 12.0, n)
    results = [c.cast(o, d, limit, z, fp, None) for c in (
        CompiledCaster(), CompiledCaster(grid_min=0), FootprintCaster())]
    np.testing.assert_allclose(results[0], results[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(results[0], results[2], rtol=1e-12, atol=1e-12)
    pieces = [(piece, b, t) for pts, b, t in polys for piece in convex_pieces(pts)]
    for i in range(n):
        # From inside a non-convex polygon a ray may meet the edge between two of its
        # pieces; from outside every polygon it meets the polygons' own edges.
        want = _brute(o[i], float(a[i]), pieces, float(z[i]), float(limit[i]))
        assert results[0][i] == pytest.approx(want, abs=1e-9), (i, o[i], a[i], z[i])
        if not any(_inside(o[i], pts) for pts, _, _ in polys):
            outer = _brute(o[i], float(a[i]), polys, float(z[i]), float(limit[i]))
            assert results[0][i] == pytest.approx(outer, abs=1e-9)


def test_polygon_bounding_circles() -> None:
    p = Polygons.build([([0j, 2 + 0j, 2 + 1j], 0.0, 1.0)])
    assert p.centre[0] == 1 + 0.5j
    assert p.radius[0] == pytest.approx(math.hypot(1.0, 0.5))
    assert p.count == 1 and p.start.tolist() == [0, 3]


@settings(max_examples=20, deadline=None)
@given(st.integers(min_value=0, max_value=2**31 - 1))
def test_convex_polygons_match_the_face_caster(seed: int) -> None:
    """Convex polygons (edges as one-sided faces) against the float32 face caster; where it
    differs by more than its noise (grazing rays), the float64 brute force decides."""
    rng = np.random.default_rng(seed)
    polys = []
    while len(polys) < 4:
        hull = convex_pieces(_random_polygon(rng))
        if len(hull) == 1:
            polys.append((hull[0], 0.0, float(rng.choice([0.3, 1.0]))))
    fp = scene(polys)
    room = Room(5.0, 5.0, 0.8)
    n = 97
    o = rng.uniform(-4.5, 4.5, n) + 1j * rng.uniform(-4.5, 4.5, n)
    a = rng.uniform(-math.pi, math.pi, n)
    z = rng.choice([0.1, 0.5], n)
    limit = np.full(n, 12.0)
    mids, normals, halves, tops = [], [], [], []
    for pts, _, top in polys:
        v = np.array([complex(x, y) for x, y in pts])
        e = np.roll(v, -1) - v
        mids.append((v + np.roll(v, -1)) / 2)
        normals.append(-1j * e / np.abs(e))
        halves.append(np.abs(e) / 2)
        tops.append(np.full(v.size, top))
    m, nrm = np.concatenate(mids), np.concatenate(normals)
    faces = Faces.concat([arena_faces(room.half_x, room.half_y, room.top),
                          Faces(m.real, m.imag, nrm.real, nrm.imag, np.concatenate(halves),
                                np.concatenate(tops))])
    want = RayCaster().cast(o.real, o.imag, np.cos(a), np.sin(a), limit, z, faces,
                            Circles.empty())
    got = CompiledCaster().cast(o, np.exp(1j * a), limit, z, fp, room)
    for i in np.flatnonzero(~np.isclose(got, want, atol=2e-4, rtol=1e-5)):
        exact = _brute(o[i], float(a[i]), polys, float(z[i]), 12.0)
        if z[i] <= room.top:
            for half, p, dd in ((room.half_x, o[i].real, math.cos(a[i])),
                                (room.half_y, o[i].imag, math.sin(a[i]))):
                exact = min(exact, (math.copysign(half, dd) - p) / dd)
        assert got[i] == pytest.approx(exact, abs=1e-9), (i, got[i], want[i], exact)
