"""The improvement phase of --refine: never worse, always conflict-free and feasible, the
optimum on cases the plain algorithms miss, and the defaults untouched."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from murdoch.consensus import allocate
from murdoch.consensus.exact import solve_exact
from murdoch.consensus.refine import RefineOptions, canonical_plan, run_refinement
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.scoring import build_problem, evaluate_plan
from murdoch.consensus.small_problems import SHAPES, small_problem


def tie_case() -> Scenario:
    """Three agents reach t0 before its window opens and all bid its full reward; the tie
    goes to a0, the only agent fast enough for t1, so t1 is left undone."""
    agents = (Agent("fast", (0.0, 0.0), speed_mps=5.0),
              Agent("slow1", (0.0, 0.0), speed_mps=1.0),
              Agent("slow2", (0.0, 5.0), speed_mps=1.0))
    tasks = (Task("t0", (10.0, 0.0), reward=100.0, discount=0.01, start_s=20.0, end_s=25.0),
             Task("t1", (100.0, 0.0), reward=100.0, discount=0.01, start_s=0.0, end_s=25.0))
    return Scenario("tie", agents, tasks)


@pytest.mark.parametrize("algorithm", ["cbba", "cbga"])
def test_refine_reaches_the_optimum_in_the_tie_case(algorithm: str) -> None:
    s = tie_case()
    plain = allocate(s, algorithm)
    refined = allocate(s, algorithm, refine=True)
    opt = solve_exact(s).total_score
    assert plain.assignment["fast"] == ["t0"] and plain.total_score == pytest.approx(100.0)
    assert plain.total_score < opt - 50
    assert refined.total_score == pytest.approx(opt)
    assert refined.assignment["fast"] == ["t1"]
    assert refined.conflict_free and refined.agreed and not refined.incomplete
    assert refined.messages > plain.messages and refined.bytes > plain.bytes
    assert refined.extra["refine"]["plain_score"] == plain.total_score


def test_refine_fills_a_group_task_plain_cbga_misses() -> None:
    # a seeded problem (uniform, tight windows, group tasks) where plain CBGA stops short
    found = 0
    for k in range(40):
        rng = np.random.default_rng([11, k])
        s = small_problem(rng, 3, 5, SHAPES[k % len(SHAPES)], groups=True)
        plain = allocate(s, "cbga")
        opt = solve_exact(s).total_score
        refined = allocate(s, "cbga", refine=True)
        if plain.total_score < opt - 1e-6 and refined.total_score > opt - 1e-6:
            found += 1
    assert found >= 3


@pytest.mark.parametrize("groups", [False, True])
def test_refine_is_conflict_free_feasible_and_never_worse(groups: bool) -> None:
    algorithm = "cbga" if groups else "cbba"
    runs = 120 if not groups else 80
    for k in range(runs):
        rng = np.random.default_rng([5, k, int(groups)])
        n = int(rng.integers(2, 6))
        m = int(rng.integers(3, 10))
        s = small_problem(rng, n, m, SHAPES[k % len(SHAPES)], groups=groups)
        plain = allocate(s, algorithm)
        refined = allocate(s, algorithm, refine=RefineOptions(seed=k))
        assert refined.conflict_free and refined.agreed, k
        assert not refined.incomplete, k
        assert refined.total_score >= plain.total_score - 1e-9, k
        p = build_problem(s)
        ids = {t.id: j for j, t in enumerate(s.tasks)}
        plan = [[ids[t] for t in refined.assignment[a.id]] for a in s.agents]
        ev = evaluate_plan(p, plan)
        assert all(ev.completed[j] for q in plan for j in q), k
        assert all(len(q) <= p.max_depth for q in plan), k


def test_agents_agree_on_a_sparse_graph() -> None:
    """On a line graph proposals take several rounds to spread; every agent ends with the
    same plan and the phase reports it converged."""
    rng = np.random.default_rng(2)
    s = small_problem(rng, 4, 7, "uniform-tight")
    ids = [a.id for a in s.agents]
    line = Scenario(s.name, s.agents, s.tasks, s.time_windows, s.max_depth,
                    CommGraph(False, tuple(itertools.pairwise(ids))))
    plain = allocate(line, "cbba")
    p = build_problem(line)
    index = {t.id: j for j, t in enumerate(line.tasks)}
    paths = [[index[t] for t in plain.assignment[a]] for a in ids]
    out = run_refinement(p, paths, line.neighbours(), RefineOptions())
    assert out.converged
    assert evaluate_plan(p, [list(q) for q in out.plan]).total_score >= plain.total_score - 1e-9
    assert out.plan == canonical_plan(p, [list(q) for q in out.plan])


def test_refine_is_skipped_on_a_disconnected_graph() -> None:
    s = tie_case()
    cut = Scenario(s.name, s.agents, s.tasks, comm_graph=CommGraph(False, (("fast", "slow1"),)))
    r = allocate(cut, "cbba", refine=True)
    assert "not strongly connected" in r.extra["refine"]["skipped"]
    assert r.total_score == allocate(cut, "cbba").total_score


def test_default_is_the_plain_algorithm() -> None:
    s = tie_case()
    assert allocate(s, "cbba") == allocate(s, "cbba", refine=False)
    assert "refine" not in allocate(s, "cbba").extra
