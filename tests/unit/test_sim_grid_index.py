"""The simulator's uniform grid (`grid_index`) and the grid-walking ray cast against brute
force: random scenes must give the same readings, bit for bit."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from player_server.sim import cast_kernel, grid_index
from player_server.sim.cast_kernel import CompiledCaster
from player_server.sim.footprint_cast import Footprints, Room

BRUTE = CompiledCaster(grid_min=10**9)
GRID = CompiledCaster(grid_min=0)


def _scene(rng: np.random.Generator, nr: int, nc: int, size: float) -> Footprints:
    return Footprints.build(rng.uniform(-size, size, nr) + 1j * rng.uniform(-size, size, nr),
                            np.exp(1j * rng.choice([0.0, 0.4, -2.0, math.pi / 2], nr)),
                            rng.uniform(0.05, 1.5, nr), rng.uniform(0.05, 1.0, nr),
                            rng.uniform(0, 1, nr),
                            rng.uniform(-size, size, nc) + 1j * rng.uniform(-size, size, nc),
                            rng.uniform(0.05, 0.6, nc), rng.uniform(0, 1, nc))


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=2**31 - 1))
def test_grid_cast_equals_brute_force_bit_for_bit(seed: int) -> None:
    """Scenes of up to a few hundred footprints, small and large rooms (or none), rays from
    inside and outside the room, shared origins, axis-parallel rays, own footprints."""
    rng = np.random.default_rng(seed)
    size = float(rng.choice([2.0, 8.0, 40.0]))
    nr, nc = int(rng.integers(0, 250)), int(rng.integers(0, 60))
    n = int(rng.integers(1, 400))
    fp = _scene(rng, nr, nc, size)
    room = Room(size + 1.0, size, 0.5) if seed % 4 else None
    o = rng.uniform(-size - 3, size + 3, n) + 1j * rng.uniform(-size - 3, size + 3, n)
    o[: n // 3] = o[0]
    d = np.exp(1j * rng.uniform(-4, 4, n))
    d[::5] = 1.0
    d[1::5] = 1j
    d[2::7] = -1.0
    limit = rng.uniform(0.1, 3 * size, n)
    limit[::11] = np.inf if room is not None else 1e3
    z = rng.choice([0.0, 0.3, 0.6, 1.0], n)
    own = None
    if nr + nc:
        own = np.where(rng.uniform(size=n) < 0.2, rng.integers(0, nr + nc, n), -1)
    assert np.array_equal(GRID.cast(o, d, limit, z, fp, room, own),
                          BRUTE.cast(o, d, limit, z, fp, room, own))


@pytest.mark.parametrize("grid_min", [0, 10**9])
def test_a_batch_cast_in_two_halves_gives_the_same_readings(
        grid_min: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """A big batch split between the caller and the helper thread (as on two CPUs, whatever
    this machine has) gives every ray the distance of one whole cast; the helper ends with
    `close`."""
    rng = np.random.default_rng(7)
    fp = _scene(rng, 300, 80, 20.0)
    room = Room(21.0, 20.0, 0.5)
    n = 5001
    o = rng.uniform(-22, 22, n) + 1j * rng.uniform(-22, 22, n)
    d = np.exp(1j * rng.uniform(-4, 4, n))
    limit = rng.uniform(0.1, 50.0, n)
    z = rng.choice([0.0, 0.3, 0.6], n)
    own = np.where(rng.uniform(size=n) < 0.1, rng.integers(0, 380, n), -1)
    whole = CompiledCaster(grid_min=grid_min, split_min=10**9).cast(o, d, limit, z, fp, room,
                                                                    own)
    monkeypatch.setattr(cast_kernel, "_two_cpus", lambda: True)
    split = CompiledCaster(grid_min=grid_min, split_min=1000)
    helpers = set()
    try:
        for _ in range(3):  # the helper is reused
            assert np.array_equal(split.cast(o, d, limit, z, fp, room, own), whole)
            assert split._helper is not None
            helpers.update(split._helper._threads)  # the executor's one worker
        (helper,) = helpers
        assert helper.is_alive() and helper is not threading.current_thread()
        small = split.cast(o[:999], d[:999], limit[:999], z[:999], fp, room, own[:999])
        assert np.array_equal(small, whole[:999])  # below split_min: one cast
    finally:
        split.close()
    assert not helper.is_alive() and split._helper is None
    monkeypatch.setattr(cast_kernel, "_two_cpus", lambda: False)
    alone = CompiledCaster(grid_min=grid_min, split_min=1000)
    assert np.array_equal(alone.cast(o, d, limit, z, fp, room, own), whole)
    assert alone._helper is None  # one CPU: never split


def test_rays_along_cell_boundaries_and_through_corners() -> None:
    """Footprints touching cell boundaries and rays running exactly along them."""
    xs, ys = np.meshgrid(np.arange(-10.0, 10.5, 1.0), np.arange(-10.0, 10.5, 1.0))
    k = xs.size
    fp = Footprints.build(xs.ravel() + 1j * ys.ravel(), np.ones(k, dtype=np.complex128),
                          np.full(k, 0.2), np.full(k, 0.2), np.ones(k),
                          np.zeros(0, dtype=np.complex128), np.zeros(0), np.zeros(0))
    grid = grid_index.build(fp.centre.real.copy(), fp.centre.imag.copy(), fp.radius,
                            (-11.0, -11.0, 11.0, 11.0))
    # rays from cell corners and boundaries, along and across the lattice
    starts = [grid.x0 + i * grid.cell + 1j * (grid.y0 + j * grid.cell)
              for i in range(0, grid.nx + 1, 3) for j in range(0, grid.ny + 1, 3)]
    a = np.arange(16) * math.pi / 8
    o = np.repeat(np.array(starts), a.size) + 0.5 + 0.5j
    d = np.exp(1j * np.tile(a, len(starts)))
    n = o.size
    lim, z = np.full(n, 30.0), np.zeros(n)
    room = Room(11.0, 11.0, 1.0)
    assert np.array_equal(GRID.cast(o, d, lim, z, fp, room), BRUTE.cast(o, d, lim, z, fp, room))


def test_non_finite_origins_and_zero_directions_fall_back_to_every_footprint() -> None:
    rng = np.random.default_rng(1)
    fp = _scene(rng, 80, 10, 5.0)
    o = np.array([np.nan + 0j, complex(np.inf, 0.0), 0.0 + 0j, 1.0 + 1j, 2.0 + 0j])
    d = np.array([1.0 + 0j, 1.0 + 0j, 1.0 + 0j, 0j, complex(np.nan, 0.0)])
    lim, z = np.array([9.0, 9.0, 9.0, np.inf, np.inf]), np.zeros(5)
    for room in (None, Room(6.0, 6.0, 1.0)):
        got, want = GRID.cast(o, d, lim, z, fp, room), BRUTE.cast(o, d, lim, z, fp, room)
        assert np.array_equal(got, want, equal_nan=True)


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=2**31 - 1))
def test_near_lists_every_disc_within_reach(seed: int) -> None:
    rng = np.random.default_rng(seed)
    k = int(rng.integers(0, 300))
    size = float(rng.choice([1.0, 10.0, 100.0]))
    cx, cy = rng.uniform(-size, size, k), rng.uniform(-size, size, k)
    r = rng.uniform(0.0, 0.05 * size, k)
    if k and seed % 5 == 0:
        cx[0] = np.nan  # left out
    grid = grid_index.build(cx, cy, r, (-size / 2, -size / 2, size / 2, size / 2))
    assert grid.nx * grid.ny <= grid_index.MAX_CELLS_PER_THING * k + 64
    for _ in range(5):
        x, y = rng.uniform(-1.2 * size, 1.2 * size, 2)
        reach = float(rng.uniform(0.0, size / 2))
        got = grid.near(float(x), float(y), reach)
        assert np.all(np.diff(got) > 0)
        # every disc whose bounding square meets the query square is listed
        want = np.flatnonzero((np.abs(cx - x) <= reach + r) & (np.abs(cy - y) <= reach + r))
        assert set(want.tolist()) <= set(got.tolist())
        assert not np.isnan(cx[got]).any()
