"""Centralised sequential greedy assignment (SGA): the reference CBBA must match.

Repeatedly give the single (agent, task) pair with the largest marginal gain (best insertion
position in that agent's path) to that agent, until no positive gain remains or every bundle
is full. Ties go to the lower agent index, then the lower task index. Single-agent tasks only.
"""

from __future__ import annotations

import numpy as np

from murdoch.consensus.allocation_result import AllocationResult, build_result
from murdoch.consensus.gains import insertion_gains
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import build_problem, path_starts


def sequential_greedy(scenario: Scenario) -> AllocationResult:
    p = build_problem(scenario)
    if (p.required != 1).any():
        raise ValueError("sequential greedy handles single-agent tasks only")
    n, m = p.n_agents, p.n_tasks
    paths: list[list[int]] = [[] for _ in range(n)]
    times: list[list[float]] = [[] for _ in range(n)]
    sizes = [0] * n
    taken = np.zeros(m, dtype=bool)
    blocked = np.zeros((n, m), dtype=bool)
    while True:
        best = (-np.inf, -1, -1, 0)
        for i in range(n):
            if sizes[i] >= p.max_depth:
                continue
            cand = p.eligible[i] & ~taken & ~blocked[i]
            if not cand.any():
                continue
            gain_l, pos = insertion_gains(p, i, paths[i], times[i], cand.tolist())
            gains = np.array(gain_l)
            gains = np.where(cand & (gains > 0), gains, -np.inf)
            j = int(np.argmax(gains))
            if gains[j] > best[0]:
                best = (float(gains[j]), i, j, int(pos[j]))
        _, i, j, at = best
        if i < 0:
            break
        path = [*paths[i][:at], j, *paths[i][at:]]
        t, ok = path_starts(p, i, path)
        if not ok:
            blocked[i, j] = True
            continue
        paths[i], times[i] = path, t
        sizes[i] += 1
        taken[j] = True
    return build_result("sga", p, paths, None, [True] * n, scenario.neighbours(), True,
                        0, 0, 0, 0)
