"""The compiled synchronous CBGA run (`cbga_kernel.run_cbga`): when it applies, and its result.

`sync_runner.allocate(scenario, "cbga")` runs it instead of the agent-based `SyncRunner` when
`compiled_cbga_unsupported(scenario, options)` is None; otherwise it falls back to the agents
and says why in the result's ``extra["engine_note"]``. Both give the same assignment, start
times, score, comm_steps, messages, bytes, rounds and flags (`test_consensus_cbga_fastpath.py`
checks them against each other on the recorded experiments and on random scenarios).
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from typing import Any

import numpy as np

from murdoch.consensus.allocation_result import AllocationResult, build_result
from murdoch.consensus.cbba_fast import ENGINE_COMPILED, kernel_arrays
from murdoch.consensus.cbga import CbgaOptions
from murdoch.consensus.conflict import rule_arrays
from murdoch.consensus.messages import encoded_size
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.scoring import Problem, build_problem

_MAX_ITEMS = 62  # equipment items travel as bits of an int64


def _items(scenario: Scenario) -> dict[str, int]:
    names: set[str] = set()
    for a in scenario.agents:
        names |= a.equipment
    for t in scenario.tasks:
        names |= t.equipment
    return {name: bit for bit, name in enumerate(sorted(names))}


def compiled_cbga_unsupported(scenario: Scenario, options: CbgaOptions | None = None
                              ) -> str | None:
    """Why the compiled run cannot take this scenario with these options, or None when it
    can (every option is supported today; they are part of the question so that a future
    one the kernel lacks can say so)."""
    if not scenario.agents or not scenario.tasks:
        return "no agents or no tasks"
    if scenario.cost == "discount" and any(t.discount < 0.0 for t in scenario.tasks):
        return "negative discount (scores that rise with time have no direct-travel bound)"
    if len(_items(scenario)) > _MAX_ITEMS:
        return f"more than {_MAX_ITEMS} kinds of equipment"
    if importlib.util.find_spec("numba") is None:
        return "numba is not installed"
    return None


def _mask(items: frozenset[str], bits: dict[str, int]) -> int:
    out = 0
    for name in items:
        out |= 1 << bits[name]
    return out


def _run(scenario: Scenario, options: CbgaOptions | None, max_rounds: int
         ) -> tuple[Problem, tuple[tuple[int, ...], ...], tuple[Any, ...]]:
    """The problem, the neighbour lists and `run_cbga`'s output."""
    from murdoch.consensus.cbga_kernel import run_cbga

    opts = options or CbgaOptions()
    p = build_problem(scenario)
    n, m = p.n_agents, p.n_tasks
    a = kernel_arrays(scenario, p)
    bits = _items(scenario)
    task_eq = np.array([_mask(e, bits) for e in p.task_equipment], dtype=np.int64)
    agent_eq = np.array([_mask(e, bits) for e in p.agent_equipment], dtype=np.int64)
    table, lut = rule_arrays()
    base = encoded_size(0, n, 0)
    per_entry = encoded_size(1, n, 0) - base
    out = run_cbga(
        p.agent_task_dist, p.task_task_dist, a.tasks, a.pre_ptr, a.pre_idx, p.speed,
        p.availability, p.eligible, p.gain_bound, min(p.max_depth, m), p.required,
        p.team_reward, p.quit_after, task_eq, agent_eq, opts.task_quitting, opts.team_reward,
        opts.quit_limit, a.nbr_ptr, a.nbr_idx, a.out_degree, a.diameter, max_rounds, table,
        lut, base, per_entry, opts.team_mode == "total")
    return p, a.neighbours, out


def allocate_compiled_cbga(scenario: Scenario, options: CbgaOptions | None = None,
                           max_rounds: int = 1000) -> AllocationResult:
    """Run synchronous CBGA to convergence with the compiled kernel (the caller checks
    `compiled_cbga_unsupported` first)."""
    p, neighbours, out = _run(scenario, options, max_rounds)
    paths_a, plen, x, rounds, steps, messages, nbytes, converged, pairs = out
    n = p.n_agents
    paths = [paths_a[i, :plen[i]].tolist() for i in range(n)]
    members = x > 0.0
    views = [[frozenset(np.flatnonzero(row).tolist()) for row in members[i]]
             for i in range(n)]
    result = build_result("cbga", p, paths, views, [True] * n, neighbours, bool(converged),
                          int(steps), int(messages), int(nbytes), int(rounds), int(pairs))
    return replace(result, extra={"engine": ENGINE_COMPILED})


def compiled_cbga_bids(scenario: Scenario, options: CbgaOptions | None = None,
                       max_rounds: int = 1000) -> list[list[list[float]]]:
    """Every agent's winning-bid matrix X (as `CbgaAgent.x`) at the end of the compiled
    run: what the agents' final beliefs are compared with, bid for bid."""
    _p, _neighbours, out = _run(scenario, options, max_rounds)
    return out[2].tolist()


def load_compiled_cbga() -> bool:
    """Load the kernel now (from its on-disk cache, or compile it when there is none) by
    solving a small group problem, so that later solves in this process are not charged
    for it; False when numba is missing. Meant for process-pool initialisers and
    benchmarks."""
    agents = (Agent("a", (0.0, 0.0), equipment=frozenset({"cam"})), Agent("b", (1.0, 0.0)),
              Agent("c", (2.0, 0.0)))
    probe = Scenario("probe", agents,
                     (Task("p", (0.0, 1.0), discount=0.1, end_s=50.0, agents_required=2,
                           equipment=frozenset({"cam"}), quit_after=2.0, team_reward=10.0),
                      Task("q", (1.0, 1.0), discount=0.1, end_s=50.0, prerequisites=("p",))))
    if compiled_cbga_unsupported(probe) is not None:
        return False
    allocate_compiled_cbga(probe)
    return True
