"""Path timing, vectorised insertion gains against brute force, and joint plan evaluation."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.consensus.gains import insertion_gains
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.scoring import (
    build_problem,
    evaluate_plan,
    path_score,
    path_times,
)


def _line_scenario() -> Scenario:
    agents = (Agent("a", (0.0, 0.0), speed_mps=1.0),)
    tasks = (Task("t1", (10.0, 0.0), reward=100, discount=0.1, start_s=0, end_s=50,
                  duration_s=5),
             Task("t2", (20.0, 0.0), reward=100, discount=0.1, start_s=30, end_s=40,
                  duration_s=5))
    return Scenario("line", agents, tasks)


def test_path_times_wait_for_windows() -> None:
    p = build_problem(_line_scenario())
    times, ok = path_times(p, 0, [0, 1])
    assert ok
    assert times.tolist() == [10.0, 30.0]  # arrives at t2 at 25 and waits for 30
    score = path_score(p, [0, 1], times)
    assert math.isclose(score, 100 * math.exp(-1.0) + 100)


def test_late_start_is_infeasible() -> None:
    p = build_problem(_line_scenario())
    _, ok = path_times(p, 0, [1, 0])  # t2 at 30, then t1 at 45 <= 50: feasible
    assert ok
    s = _line_scenario()
    tight = Scenario("tight", s.agents, (s.tasks[0].__class__(
        "t1", (10.0, 0.0), reward=100, start_s=0, end_s=40, duration_s=5), s.tasks[1]))
    _, ok = path_times(build_problem(tight), 0, [1, 0])
    assert not ok


def test_without_time_windows_discount_counts_from_zero() -> None:
    s = _line_scenario()
    free = Scenario("free", s.agents, s.tasks, time_windows=False)
    p = build_problem(free)
    times, ok = path_times(p, 0, [0, 1])
    assert ok and times.tolist() == [10.0, 25.0]
    assert math.isclose(path_score(p, [0, 1], times),
                        100 * math.exp(-1.0) + 100 * math.exp(-2.5))


def _brute(p, agent, path):
    base_t, _ = path_times(p, agent, path)
    base = path_score(p, path, base_t)
    out = np.full(p.n_tasks, -np.inf)
    for j in range(p.n_tasks):
        if j in path:
            continue
        for n in range(len(path) + 1):
            cand = [*path[:n], j, *path[n:]]
            t, ok = path_times(p, agent, cand)
            if ok:
                out[j] = max(out[j], path_score(p, cand, t) - base)
    return out


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.integers(0, 5), st.booleans())
def test_vectorised_gains_match_brute_force(seed: int, length: int, windows: bool) -> None:
    rng = np.random.default_rng(seed)
    s = make_scenario("g", rng, [frozenset()] * 2, [TaskSpec()] * 8)
    if not windows:
        s = Scenario(s.name, s.agents, s.tasks, time_windows=False)
    p = build_problem(s)
    # a feasible path built by taking tasks in window order while it stays feasible
    path: list[int] = []
    for j in np.argsort(p.window_start):
        if len(path) >= length:
            break
        if path_times(p, 0, [*path, int(j)])[1]:
            path.append(int(j))
    times, ok = path_times(p, 0, path)
    assert ok
    gain_l, pos = insertion_gains(p, 0, path, times.tolist(), [j not in path
                                                             for j in range(p.n_tasks)])
    gains = np.array(gain_l)
    want = _brute(p, 0, path)
    finite = np.isfinite(want)
    assert (np.isfinite(gains) == finite).all()
    assert np.allclose(gains[finite], want[finite], rtol=1e-9, atol=1e-9)
    for j in np.flatnonzero(finite):  # the reported position achieves the gain
        cand = [*path[: pos[j]], int(j), *path[pos[j]:]]
        t, ok = path_times(p, 0, cand)
        assert ok
        assert math.isclose(path_score(p, cand, t) - path_score(p, path, times), gains[j],
                            rel_tol=1e-9, abs_tol=1e-9)


def test_group_task_starts_when_the_last_member_arrives() -> None:
    agents = (Agent("near", (0.0, 0.0)), Agent("far", (30.0, 0.0)))
    tasks = (Task("lift", (5.0, 0.0), reward=10, discount=0.0, start_s=0, end_s=100,
                  duration_s=2, agents_required=2),)
    p = build_problem(Scenario("g", agents, tasks))
    ev = evaluate_plan(p, [[0], [0]])
    assert ev.completed == (True,)
    assert ev.task_start[0] == 25.0
    assert ev.total_score == 20.0  # each member earns the task's score
    half = evaluate_plan(p, [[0], []])
    assert half.completed == (False,) and half.total_score == 0.0


def test_group_members_waiting_on_each_other_in_a_cycle_are_broken() -> None:
    agents = (Agent("a", (0.0, 0.0)), Agent("b", (1.0, 0.0)))
    tasks = tuple(Task(f"t{n}", (float(n), 1.0), reward=10, agents_required=2)
                  for n in range(2))
    p = build_problem(Scenario("cycle", agents, tasks))
    ev = evaluate_plan(p, [[0, 1], [1, 0]])
    assert sum(ev.completed) == 1
