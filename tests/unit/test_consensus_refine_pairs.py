"""The two-agent re-plan of --refine, its round budget and what the result reports."""

from __future__ import annotations

import numpy as np
import pytest

from murdoch.consensus import allocate
from murdoch.consensus.exact import solve_exact
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.refine import RefineOptions, complete_graph, step_limit
from murdoch.consensus.small_problems import SHAPES, small_problem


def test_two_agents_reach_the_optimum_with_single_agent_tasks() -> None:
    # with two agents the pair re-plan covers every task: the first step finds the optimum
    for k in range(20):
        rng = np.random.default_rng([31, k])
        s = small_problem(rng, 2, int(rng.integers(4, 8)), SHAPES[k % len(SHAPES)])
        opt = solve_exact(s).total_score
        refined = allocate(s, "cbba", refine=True)
        assert refined.total_score == pytest.approx(opt, rel=1e-9, abs=1e-9), k
        assert refined.conflict_free and refined.agreed and not refined.incomplete


def test_pairs_raise_the_worst_case_over_one_task_moves() -> None:
    worst = {True: 1.0, False: 1.0}
    for k in range(30):
        rng = np.random.default_rng([32, k])
        s = small_problem(rng, 3, 7, SHAPES[k % len(SHAPES)], groups=True)
        opt = solve_exact(s).total_score
        for pairs in (True, False):
            r = allocate(s, "cbga", refine=RefineOptions(pairs=pairs, budget=None))
            assert r.conflict_free and not r.incomplete, k
            worst[pairs] = min(worst[pairs], r.total_score / opt if opt > 0 else 1.0)
    assert worst[True] > worst[False]
    assert worst[True] >= 0.85


def test_step_limit_follows_the_plain_rounds() -> None:
    opts = RefineOptions()
    # a step is one round on a complete graph, and the paths take one (none with the
    # opening, which carries the paths with the first proposals)
    assert step_limit(opts, 12, 1) == 5
    assert step_limit(opts, 12, 1, opening=True) == 6
    assert step_limit(opts, 6, 1) == 2
    assert step_limit(opts, 3, 1, opening=True) == 1  # half of 3 rounds, rounded down
    assert step_limit(opts, 1, 1, opening=True) == 1  # at least min_rounds = 1 round
    assert step_limit(RefineOptions(min_rounds=3), 1, 1) == 2
    assert step_limit(opts, 12, 3) == 1  # a step may take the diameter in rounds
    assert step_limit(opts, 12, 3, opening=True) == 2
    assert step_limit(RefineOptions(budget=None, max_steps=7), 2, 1) == 7
    assert step_limit(RefineOptions(max_steps=2), 40, 1) == 2
    assert complete_graph([[1, 2], [0, 2], [0, 1]])
    assert not complete_graph([[1], [0, 2], [1]])


def test_messages_stay_within_half_again_the_plain_run_at_ten_agents() -> None:
    variant = EXPERIMENTS["fig5"][0]  # CBBA, 20 single-agent tasks
    for run in range(3):
        s = variant.make(10, run_seed(0, 10, run))
        plain = allocate(s, variant.algorithm, variant.options)
        refined = allocate(s, variant.algorithm, variant.options, refine=True)
        assert refined.messages <= 1.5 * plain.messages
        phase = refined.extra["refine"]
        assert phase["rounds"] <= max(1, plain.comm_steps // 2)
        assert refined.messages == plain.messages + phase["messages"]
        assert refined.total_score >= plain.total_score - 1e-9


@pytest.mark.parametrize(("algorithm", "compiled", "says"), [
    ("cbba", True, "on top of the compiled engine's result"),
    ("cbga", True, "on top of the compiled engine's result"),
    ("cbba", False, "after the agents' run"),
])
def test_engine_note_says_where_the_phase_runs(algorithm: str, compiled: bool,
                                               says: str) -> None:
    s = small_problem(np.random.default_rng(3), 3, 5, "uniform-loose")
    r = allocate(s, algorithm, compiled=compiled, refine=True)
    assert says in r.extra["engine_note"]
    assert r.extra["engine"] == ("compiled" if compiled else "agents")
    if not compiled:
        assert r.extra["engine_note"].startswith("not requested; ")


def test_joint_score_equals_evaluate_plan() -> None:
    from murdoch.consensus.joint_score import joint_score
    from murdoch.consensus.scoring import build_problem, evaluate_plan

    checked = 0
    for k in range(60):
        rng = np.random.default_rng([33, k])
        s = small_problem(rng, int(rng.integers(2, 5)), int(rng.integers(3, 9)),
                          SHAPES[k % len(SHAPES)], groups=bool(k % 2))
        p = build_problem(s)
        for _ in range(20):
            paths = [[] for _ in range(p.n_agents)]
            for j in rng.permutation(p.n_tasks).tolist():
                for i in rng.permutation(p.n_agents)[: int(rng.integers(0, 3))].tolist():
                    paths[i].append(j)
            ev = evaluate_plan(p, paths)
            total, completed = joint_score(p, paths)
            assert total == pytest.approx(ev.total_score, rel=1e-12, abs=1e-9)
            assert tuple(completed) == ev.completed
            checked += sum(completed)
    assert checked > 100


def test_a_fast_converging_group_run_stays_within_half_again() -> None:
    # fig10 #2 at 10 agents, run 3: plain CBGA converges in 3 rounds; the opening and the
    # round budget leave the phase one round (it took four before: paths, then proposals)
    variant = EXPERIMENTS["fig10"][1]
    s = variant.make(10, run_seed(0, 10, 3))
    plain = allocate(s, variant.algorithm, variant.options)
    refined = allocate(s, variant.algorithm, variant.options, refine=True)
    assert plain.comm_steps == 3
    assert refined.extra["refine"]["rounds"] == 1
    assert refined.comm_steps <= 1.5 * plain.comm_steps
    assert refined.messages <= 1.5 * plain.messages
    assert refined.bytes <= 1.5 * plain.bytes
    assert refined.total_score >= plain.total_score - 1e-9
    assert refined.conflict_free and not refined.incomplete
