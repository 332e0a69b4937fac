"""The compiled synchronous CBBA run (`cbba_kernel.run_cbba`): when it applies, and its result.

`sync_runner.allocate(scenario, "cbba")` runs it instead of the agent-based `SyncRunner` when
`compiled_cbba_unsupported(scenario)` is None: numba is installed and no discount is
negative. Otherwise it falls back to the agents
and says why in the result's ``extra["engine_note"]``. Both give the same assignment, start
times, score, comm_steps, messages and bytes (`test_consensus_fastpath.py` checks them
against each other on the recorded and on random scenarios).
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from murdoch.consensus.allocation_result import AllocationResult, build_result, graph_diameter
from murdoch.consensus.conflict import rule_arrays
from murdoch.consensus.messages import encoded_size
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.scoring import Problem, build_problem

ENGINE_COMPILED = "compiled"  # result.extra["engine"]; the agents' runs say "agents"


def compiled_cbba_unsupported(scenario: Scenario) -> str | None:
    """Why the compiled run cannot take this scenario, or None when it can."""
    if any(t.agents_required != 1 for t in scenario.tasks):
        return "group tasks (CBBA rejects them)"
    if scenario.cost == "discount" and any(t.discount < 0.0 for t in scenario.tasks):
        return "negative discount (scores that rise with time have no direct-travel bound)"
    if not scenario.agents or not scenario.tasks:
        return "no agents or no tasks"
    if importlib.util.find_spec("numba") is None:
        return "numba is not installed"
    return None


@dataclass(frozen=True)
class KernelArrays:
    """What both compiled runs take besides the problem: the communication graph as
    neighbour lists and in CSR form (nbr_idx[nbr_ptr[i]:nbr_ptr[i + 1]] are agent i's) with
    each agent's out-degree and the graph's diameter; the tasks' rows (window start, latest
    start, duration, score reference time, reward, discount, linear-cost flag) and their
    prerequisites in CSR form."""

    neighbours: Any
    nbr_ptr: np.ndarray
    nbr_idx: np.ndarray
    out_degree: np.ndarray
    diameter: int
    tasks: np.ndarray
    pre_ptr: np.ndarray
    pre_idx: np.ndarray


def kernel_arrays(scenario: Scenario, p: Problem) -> KernelArrays:
    n, m = p.n_agents, p.n_tasks
    neighbours = scenario.neighbours()
    nbr_ptr = np.zeros(n + 1, dtype=np.int64)
    for i, ks in enumerate(neighbours):
        nbr_ptr[i + 1] = nbr_ptr[i] + len(ks)
    nbr_idx = np.array([k for ks in neighbours for k in ks], dtype=np.int64)
    out_degree = np.zeros(n, dtype=np.int64)
    for ks in neighbours:
        for k in ks:
            out_degree[k] += 1
    # a full graph's diameter is 1 (graph_diameter's answer, without the search)
    diameter = (1 if scenario.comm_graph.edges is None
                else graph_diameter(neighbours, [True] * n))
    linear = np.full(m, 1.0 if p.lists.linear else 0.0)
    tasks = np.stack([p.window_start, p.window_end, p.duration, p.score_ref, p.reward,
                      p.discount, linear])
    pre_ptr = np.zeros(m + 1, dtype=np.int64)
    for j, pre in enumerate(p.prereqs):
        pre_ptr[j + 1] = pre_ptr[j] + len(pre)
    pre_idx = np.array([q for pre in p.prereqs for q in pre], dtype=np.int64)
    return KernelArrays(neighbours, nbr_ptr, nbr_idx, out_degree, diameter, tasks, pre_ptr,
                        pre_idx)


def allocate_compiled(scenario: Scenario, max_rounds: int = 1000) -> AllocationResult:
    """Run synchronous CBBA to convergence with the compiled kernel (the caller checks
    `compiled_cbba_unsupported` first)."""
    from murdoch.consensus.cbba_kernel import run_cbba

    p = build_problem(scenario)
    n, m = p.n_agents, p.n_tasks
    a = kernel_arrays(scenario, p)
    active = [True] * n
    table, lut = rule_arrays()
    base = encoded_size(0, n, 0)
    per_entry = encoded_size(1, n, 0) - base
    paths_a, plen, z, _y, _t, rounds, steps, messages, nbytes, converged, pairs = run_cbba(
        p.agent_task_dist, p.task_task_dist, a.tasks, a.pre_ptr, a.pre_idx, p.speed,
        p.availability, p.eligible, p.gain_bound, min(p.max_depth, m), a.nbr_ptr, a.nbr_idx,
        a.out_degree, a.diameter, max_rounds, table, lut, base, per_entry)
    paths = [paths_a[i, :plen[i]].tolist() for i in range(n)]
    views = [[frozenset() if w < 0 else frozenset((w,)) for w in row] for row in z.tolist()]
    result = build_result("cbba", p, paths, views, active, a.neighbours, bool(converged),
                          int(steps), int(messages), int(nbytes), int(rounds), int(pairs))
    return replace(result, extra={"engine": ENGINE_COMPILED})


def load_compiled_cbba() -> bool:
    """Load the kernel now (from its on-disk cache, or compile it when there is none) by
    solving a two-task problem, so that later solves in this process are not charged for it;
    False when numba is missing. Meant for process-pool initialisers and benchmarks."""
    probe = Scenario("probe", (Agent("a", (0.0, 0.0)), Agent("b", (1.0, 0.0))),
                     (Task("p", (0.0, 1.0), discount=0.1, end_s=50.0),
                      Task("q", (1.0, 1.0), discount=0.1, end_s=50.0)))
    if compiled_cbba_unsupported(probe) is not None:
        return False
    allocate_compiled(probe)
    return True
