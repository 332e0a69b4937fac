"""The fast paths of bundle building agree with plain references.

- `PathGains` (cached, pruned insertion gains) equals brute-force re-timing of every
  insertion, with prerequisites and group not-before times;
- its upper bounds hold on every path grown from the one they were found on;
- allocations with bound pruning equal allocations that evaluate every candidate;
- the list-based conflict resolution takes the same actions as the table evaluator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus import gains as gains_module
from murdoch.consensus.conflict import NONE, resolve, resolve_lists
from murdoch.consensus.experiments import EXPERIMENTS, TaskSpec, make_scenario, run_seed
from murdoch.consensus.gains import PathGains
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import Problem, build_problem, path_starts, task_scores
from murdoch.consensus.sync_runner import allocate


def _score(p: Problem, path: list[int], times: list[float]) -> float:
    if not path:
        return 0.0
    return float(task_scores(p, np.asarray(path), np.asarray(times)).sum())


def _brute(p: Problem, path: list[int], times: list[float], c: int,
           not_before: float) -> float:
    """Best gain of inserting c by re-timing the whole path at every position; the path
    keeps its times as given (they may include partners' waits), later tasks move only
    as far as c pushes them."""
    base = _score(p, path, times)
    best = -math.inf
    for n in range(len(path) + 1):
        cand = [*path[:n], c, *path[n:]]
        bounds = {j: t for j, t in zip(path, times, strict=True)}
        bounds[c] = not_before
        t, ok = path_starts(p, 0, cand, bounds)
        if ok:
            best = max(best, _score(p, cand, t) - base)
    return best


def _random_path(p: Problem, rng: np.random.Generator, length: int) -> list[int]:
    path: list[int] = []
    for j in rng.permutation(p.n_tasks):
        if len(path) >= length:
            break
        for n in range(len(path) + 1):
            cand = [*path[:n], int(j), *path[n:]]
            if path_starts(p, 0, cand)[1]:
                path = cand
                break
    return path


def _problem(seed: int, prerequisites: bool) -> Problem:
    rng = np.random.default_rng(seed)
    specs = [TaskSpec(prerequisite=(j - 4 if prerequisites and j >= 4 and j % 2 else None))
             for j in range(9)]
    return build_problem(make_scenario("g", rng, [frozenset()] * 2, specs))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.integers(0, 6), st.booleans(),
       st.sampled_from([0.0, 40.0, 120.0]))
def test_gains_match_brute_force(seed: int, length: int, prerequisites: bool,
                                 not_before: float) -> None:
    p = _problem(seed, prerequisites)
    path = _random_path(p, np.random.default_rng(seed + 1), length)
    times, ok = path_starts(p, 0, path)
    assert ok
    gains = PathGains(p, 0, path, times)
    for c in range(p.n_tasks):
        if c in path:
            continue
        got, at = gains.gain(c, not_before)
        want = _brute(p, path, times, c, not_before)
        assert math.isfinite(got) == math.isfinite(want), (c, got, want)
        if math.isfinite(want):
            assert got == pytest.approx(want, rel=1e-9, abs=1e-9)
            # the reported position achieves it
            cand = [*path[:at], c, *path[at:]]
            bounds = dict(zip(path, times, strict=True))
            bounds[c] = not_before
            t, fits = path_starts(p, 0, cand, bounds)
            assert fits
            assert _score(p, cand, t) - _score(p, path, times) == pytest.approx(
                got, rel=1e-9, abs=1e-9)
        assert gains.gain(c, not_before) == (got, at)  # cached


@settings(max_examples=30, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.integers(0, 3), st.integers(1, 4), st.booleans())
def test_bounds_hold_on_grown_paths(seed: int, start_len: int, grow: int,
                                    prerequisites: bool) -> None:
    p = _problem(seed, prerequisites)
    rng = np.random.default_rng(seed + 7)
    path = _random_path(p, rng, start_len)
    times, _ = path_starts(p, 0, path)
    ancestor = PathGains(p, 0, path, times)
    for c in range(p.n_tasks):
        if c not in path:
            ancestor.gain(c)
    bounds = ancestor.bounds()
    # grow the path by feasible insertions, as bundle building does
    for _ in range(grow):
        options = [(c, n) for c in range(p.n_tasks) if c not in path
                   for n in range(len(path) + 1)
                   if path_starts(p, 0, [*path[:n], c, *path[n:]])[1]]
        if not options:
            break
        c, n = options[int(rng.integers(len(options)))]
        path = [*path[:n], c, *path[n:]]
    times, _ = path_starts(p, 0, path)
    grown = PathGains(p, 0, path, times, dict(bounds))
    for c in range(p.n_tasks):
        if c in path:
            continue
        bound = grown.upper_bound(c)
        gain, _ = PathGains(p, 0, path, times).gain(c)
        assert gain <= bound, (c, gain, bound)


def _without_pruning(monkeypatch: pytest.MonkeyPatch) -> None:
    """No bound ever excludes a candidate: every one is evaluated."""
    monkeypatch.setattr(gains_module, "_ROBUST_S", math.inf)
    monkeypatch.setattr(PathGains, "_bound_from", lambda self, c, floor: math.inf)


CASES = [("fig5", 0, 6, 3), ("fig5", 1, 7, 4), ("fig5", 2, 5, 1), ("fig7", 3, 10, 2),
         ("fig8", 2, 6, 0), ("fig10", 1, 6, 2), ("fig10", 2, 5, 3)]


@pytest.mark.parametrize(("experiment", "variant", "agents", "run"), CASES)
def test_pruned_bundles_equal_full_evaluation(experiment: str, variant: int, agents: int,
                                              run: int, monkeypatch: pytest.MonkeyPatch
                                              ) -> None:
    v = EXPERIMENTS[experiment][variant]
    scenario = v.make(agents, run_seed(11, agents, run))
    fast = allocate(scenario, v.algorithm, v.options)  # type: ignore[arg-type]
    _without_pruning(monkeypatch)
    plain = allocate(scenario, v.algorithm, v.options)  # type: ignore[arg-type]
    assert fast == plain


@settings(max_examples=15, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(2, 6), st.integers(3, 12))
def test_pruned_cbba_equals_full_evaluation_on_random_scenarios(seed: int, n_agents: int,
                                                                n_tasks: int) -> None:
    rng = np.random.default_rng(seed)
    s = make_scenario("r", rng, [frozenset()] * n_agents, [TaskSpec()] * n_tasks)
    s = Scenario(s.name, s.agents, s.tasks, True)
    fast = allocate(s, "cbba")
    with pytest.MonkeyPatch.context() as mp:
        _without_pruning(mp)
        assert allocate(s, "cbba") == fast


agent = st.sampled_from([NONE, 0, 1, 2, 3])


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(st.tuples(agent, agent, st.sampled_from([0.0, 1.0, 2.0]),
                          st.sampled_from([0.0, 1.0, 2.0])), min_size=1, max_size=8),
       st.lists(st.sampled_from([-math.inf, 1.0, 2.0, 3.0]), min_size=8, max_size=8))
def test_list_resolution_matches_the_table(rows: list[tuple[int, int, float, float]],
                                           stamps: list[float]) -> None:
    i, k = 0, 1
    z_k = [r[0] for r in rows]
    z_i = [r[1] for r in rows]
    y_k = [0.0 if r[0] == NONE else r[2] for r in rows]
    y_i = [0.0 if r[1] == NONE else r[3] for r in rows]
    s_k = [*stamps[:4], -math.inf]
    s_i = [*stamps[4:], -math.inf]
    y_new, z_new = list(y_i), list(z_i)
    changed = resolve_lists(i, k, y_new, z_new, s_i, y_k, z_k, s_k)
    for n in range(len(rows)):
        action, _ = resolve(i, k, y_k[n], z_k[n], y_i[n], z_i[n],
                            dict(enumerate(stamps[:4])), dict(enumerate(stamps[4:])))
        if action == 1:
            want = (y_k[n], z_k[n])
        elif action == 2:
            want = (0.0, NONE)
        else:
            want = (y_i[n], z_i[n])
        assert (y_new[n], z_new[n]) == want
    assert changed == ((y_new, z_new) != (y_i, z_i))
