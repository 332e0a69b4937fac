"""The exact solver against brute-force enumeration of every plan on tiny instances."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from murdoch.consensus.exact import solve_exact
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.scoring import Problem, build_problem, evaluate_plan
from murdoch.consensus.small_problems import SHAPES, small_problem


def brute_force(p: Problem) -> float:
    """Every assignment of every task to none or an allowed group, every order per agent."""
    options = []
    for j in range(p.n_tasks):
        opts: list[tuple[int, ...]] = [()]
        for combo in itertools.combinations(range(p.n_agents), int(p.required[j])):
            if all(p.eligible[i, j] for i in combo):
                opts.append(combo)
        options.append(opts)
    best = 0.0
    for pick in itertools.product(*options):
        sets: list[list[int]] = [[] for _ in range(p.n_agents)]
        for j, combo in enumerate(pick):
            for i in combo:
                sets[i].append(j)
        if any(len(s) > p.max_depth for s in sets):
            continue
        for orders in itertools.product(*[itertools.permutations(s) for s in sets]):
            best = max(best, evaluate_plan(p, [list(o) for o in orders]).total_score)
    return best


@pytest.mark.parametrize("groups", [False, True])
def test_exact_equals_brute_force_on_tiny_problems(groups: bool) -> None:
    for k in range(25):
        rng = np.random.default_rng([3, k, int(groups)])
        n = int(rng.integers(2, 4))
        s = small_problem(rng, n, 4, SHAPES[k % len(SHAPES)], groups=groups)
        p = build_problem(s)
        sol = solve_exact(p)
        assert sol.total_score == pytest.approx(brute_force(p), abs=1e-6), k
        # the reported plan scores what the solver says
        plan = [list(q) for q in sol.paths]
        assert evaluate_plan(p, plan).total_score == pytest.approx(sol.total_score, abs=1e-9)


def test_exact_rejects_prerequisites() -> None:
    s = Scenario("pre", (Agent("a", (0.0, 0.0)),),
                 (Task("t0", (1.0, 0.0)), Task("t1", (2.0, 0.0), prerequisites=("t0",))))
    with pytest.raises(ValueError, match="prerequisites"):
        solve_exact(s)
