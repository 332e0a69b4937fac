"""Tasks added and agents removed mid-run: the allocators re-converge without conflict."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from murdoch.consensus import SyncRunner
from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.consensus.scenario import CommGraph, Scenario, Task


def _scenario(seed: int, specs: list[TaskSpec], n_agents: int = 5, ring: bool = False
              ) -> Scenario:
    s = make_scenario("dyn", np.random.default_rng(seed), [frozenset()] * n_agents, specs)
    ids = [a.id for a in s.agents]
    edges = list(pairwise(ids)) + ([(ids[-1], ids[0])] if ring else [])
    return Scenario(s.name, s.agents, s.tasks, comm_graph=CommGraph(False, tuple(edges)))


@pytest.mark.parametrize("algorithm", ["cbba", "cbga"])
def test_added_tasks_are_allocated(algorithm: str) -> None:
    specs = [TaskSpec(1 if algorithm == "cbba" else 1 + j % 2) for j in range(8)]
    runner = SyncRunner(_scenario(1, specs), algorithm)  # type: ignore[arg-type]
    first = runner.run()
    assert first.converged and first.conflict_free
    extra = [Task(f"new{n}", (50.0 + n, 50.0, 5.0), reward=500, discount=0.0, start_s=0,
                  end_s=1000, duration_s=1) for n in range(3)]
    runner.add_tasks(extra)
    again = runner.run()
    assert again.converged and again.conflict_free and again.agreed
    won = {t for ts in again.assignment.values() for t in ts}
    assert {"new0", "new1", "new2"} <= won  # worth far more than anything else


@pytest.mark.parametrize("algorithm", ["cbba", "cbga"])
def test_removed_agent_tasks_are_reallocated(algorithm: str) -> None:
    specs = [TaskSpec(1 if algorithm == "cbba" else 1 + j % 2) for j in range(10)]
    runner = SyncRunner(_scenario(2, specs, ring=True), algorithm)  # type: ignore[arg-type]
    first = runner.run()
    busiest = max(first.assignment, key=lambda a: len(first.assignment[a]))
    lost = set(first.assignment[busiest])
    assert lost
    runner.remove_agent(busiest)
    again = runner.run()
    assert busiest not in again.assignment
    assert again.converged and again.conflict_free and again.agreed
    # a ring minus one agent is still connected
    still = {t for ts in again.assignment.values() for t in ts}
    assert still & lost or again.total_score > 0


def test_cbba_refuses_group_tasks() -> None:
    runner = SyncRunner(_scenario(3, [TaskSpec(1)] * 3), "cbba")
    with pytest.raises(ValueError, match="single-agent"):
        runner.add_tasks([Task("g", (0.0, 0.0, 0.0), agents_required=2)])
