"""Seeded scenario generators for the CBGA paper's experiments, and one run of each.

Every set-up has 20 tasks in a 100 m x 100 m x 10 m volume with time windows (opening in the
first 200 s, latest start 20-60 s later, 5-15 s long, reward 100, discount 0.02 per second)
and 1-10 agents flying at 2 m/s from random positions, fully connected. The random draws
depend only on (seed, agent count, run), so every variant of an experiment sees the same
geometry and the variants are compared pairwise.

Experiments (variants):
- ``fig5``: CBBA on 20 single-agent tasks; CBGA on 20 two-agent tasks; CBGA on 10 + 10.
- ``fig7``: CBGA on 20 four-agent tasks: base, task quitting, team reward, both.
- ``fig8``: heterogeneous agents: A/B on A and B tasks; A/B on A, B and AB tasks (7-7-6);
  A/B/C on A, AB and ABC tasks (8-6-6).
- ``fig10``: CBGA on two-agent tasks: no prerequisites; prerequisites on half the tasks
  (10 base, 5 needing a base task, 5 needing one of those); the same with no time window
  on the follow-up tasks.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from murdoch.consensus.cbga import CbgaOptions
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.sync_runner import allocate

N_TASKS = 20
AREA_M = (100.0, 100.0, 10.0)
SPEED_MPS = 2.0
REWARD = 100.0
DISCOUNT = 0.02
QUIT_AFTER_ROUNDS = 5.0


@dataclass(frozen=True)
class TaskSpec:
    required: int = 1
    equipment: frozenset[str] = frozenset()
    prerequisite: int | None = None  # index of the prerequisite task
    open_window: bool = False  # no time window


def geometry(rng: np.random.Generator, n_agents: int, n_tasks: int = N_TASKS
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    area = np.array(AREA_M)
    agent_pos = rng.uniform(0, 1, (n_agents, 3)) * area
    task_pos = rng.uniform(0, 1, (n_tasks, 3)) * area
    start = rng.uniform(0, 200, n_tasks)
    window = rng.uniform(20, 60, n_tasks)
    duration = rng.uniform(5, 15, n_tasks)
    return agent_pos, task_pos, start, start + window, duration


def make_scenario(name: str, rng: np.random.Generator, agent_equipment: list[frozenset[str]],
                  specs: list[TaskSpec], team_reward: bool = False,
                  quit_after: float | None = None) -> Scenario:
    n = len(agent_equipment)
    agent_pos, task_pos, start, end, duration = geometry(rng, n, len(specs))
    agents = tuple(
        Agent(id=f"a{i + 1}", pos=tuple(float(v) for v in agent_pos[i]), speed_mps=SPEED_MPS,
              equipment=agent_equipment[i])
        for i in range(n))
    tasks = []
    for j, spec in enumerate(specs):
        tasks.append(Task(
            id=f"t{j + 1}", pos=tuple(float(v) for v in task_pos[j]), reward=REWARD,
            discount=DISCOUNT,
            start_s=0.0 if spec.open_window else float(start[j]),
            end_s=math.inf if spec.open_window else float(end[j]),
            duration_s=float(duration[j]), agents_required=spec.required,
            equipment=spec.equipment,
            prerequisites=() if spec.prerequisite is None else (f"t{spec.prerequisite + 1}",),
            quit_after=quit_after if spec.required > 1 else None,
            team_reward=REWARD if team_reward and spec.required > 1 else 0.0))
    return Scenario(name=name, agents=agents, tasks=tuple(tasks), time_windows=True)


def _plain(n: int) -> list[frozenset[str]]:
    return [frozenset()] * n


def _typed(n: int, types: str) -> list[frozenset[str]]:
    return [frozenset({types[i % len(types)]}) for i in range(n)]


def _eq(s: str) -> frozenset[str]:
    return frozenset(s)


def _prereq_specs(open_followups: bool) -> list[TaskSpec]:
    specs = [TaskSpec(2) for _ in range(10)]
    specs += [TaskSpec(2, prerequisite=k, open_window=open_followups) for k in range(5)]
    specs += [TaskSpec(2, prerequisite=10 + k, open_window=open_followups) for k in range(5)]
    return specs


@dataclass(frozen=True)
class Variant:
    name: str
    algorithm: str
    options: CbgaOptions
    make: Callable[[int, np.random.Generator], Scenario]


def _v(name: str, algorithm: str, make: Callable[[int, np.random.Generator], Scenario],
       quitting: bool = False, team: bool = False) -> Variant:
    return Variant(name, algorithm, CbgaOptions(task_quitting=quitting, team_reward=team), make)


def _four_agent_maker(quitting: bool, team: bool
                      ) -> Callable[[int, np.random.Generator], Scenario]:
    def make(n: int, rng: np.random.Generator) -> Scenario:
        return make_scenario("fig7", rng, _plain(n), [TaskSpec(4)] * 20, team_reward=team,
                             quit_after=QUIT_AFTER_ROUNDS if quitting else None)
    return make


EXPERIMENTS: dict[str, tuple[Variant, ...]] = {
    "fig5": (
        _v("CBBA single-agent", "cbba",
           lambda n, r: make_scenario("fig5-single", r, _plain(n), [TaskSpec(1)] * 20)),
        _v("CBGA two-agent", "cbga",
           lambda n, r: make_scenario("fig5-two", r, _plain(n), [TaskSpec(2)] * 20)),
        _v("CBGA mix 10+10", "cbga",
           lambda n, r: make_scenario("fig5-mix", r, _plain(n),
                                      [TaskSpec(1 + (j % 2)) for j in range(20)])),
    ),
    "fig7": tuple(
        _v(label, "cbga", _four_agent_maker(q, t), quitting=q, team=t)
        for label, q, t in (("CBGA", False, False), ("quitting", True, False),
                            ("team reward", False, True), ("quitting + team", True, True))
    ),
    "fig8": (
        _v("#1 A/B solo", "cbga",
           lambda n, r: make_scenario("fig8-1", r, _typed(n, "AB"),
                                      [TaskSpec(1, _eq("A"))] * 10 + [TaskSpec(1, _eq("B"))] * 10)),
        _v("#2 A, B, AB", "cbga",
           lambda n, r: make_scenario("fig8-2", r, _typed(n, "AB"),
                                      [TaskSpec(1, _eq("A"))] * 7 + [TaskSpec(1, _eq("B"))] * 7
                                      + [TaskSpec(2, _eq("AB"))] * 6)),
        _v("#3 A, AB, ABC", "cbga",
           lambda n, r: make_scenario("fig8-3", r, _typed(n, "ABC"),
                                      [TaskSpec(1, _eq("A"))] * 8 + [TaskSpec(2, _eq("AB"))] * 6
                                      + [TaskSpec(3, _eq("ABC"))] * 6)),
    ),
    "fig10": (
        _v("#1 no prerequisites", "cbga",
           lambda n, r: make_scenario("fig10-1", r, _plain(n), [TaskSpec(2)] * 20)),
        _v("#2 prerequisites", "cbga",
           lambda n, r: make_scenario("fig10-2", r, _plain(n), _prereq_specs(False))),
        _v("#3 prerequisites, open follow-ups", "cbga",
           lambda n, r: make_scenario("fig10-3", r, _plain(n), _prereq_specs(True))),
    ),
}

DEFAULT_AGENTS: dict[str, tuple[int, ...]] = {
    "fig5": tuple(range(1, 11)), "fig7": (10,), "fig8": tuple(range(1, 11)),
    "fig10": tuple(range(1, 11)),
}


def run_seed(seed: int, n_agents: int, run: int) -> np.random.Generator:
    return np.random.default_rng([seed, n_agents, run])


@dataclass(frozen=True)
class RunRecord:
    experiment: str
    variant: str
    n_agents: int
    run: int
    score: float
    steps: int
    messages: int
    bytes: int
    converged: bool
    conflict_free: bool
    solve_s: float
    pairwise_steps: int = 0
    bytes_dense: int = 0
    cost: str = "discount"
    team_mode: str = "bonus"


def run_one(experiment: str, variant_index: int, n_agents: int, run: int, seed: int,
            clock: Callable[[], float] = time.perf_counter, refine: bool = False,
            cost: str = "discount", team_mode: str = "bonus") -> RunRecord:
    """Generate one scenario and allocate it (the unit of work of a sweep); with `refine`
    the improvement phase follows and the variant is named '<name> +refine'. `cost`
    (`scenario.COSTS`) is how tasks score, `team_mode` (`cbga.TEAM_MODES`) how the variants
    with team reward bid; the geometry depends on neither."""
    variant = EXPERIMENTS[experiment][variant_index]
    scenario = replace(variant.make(n_agents, run_seed(seed, n_agents, run)), cost=cost)
    options = replace(variant.options, team_mode=team_mode)
    t0 = clock()
    result = allocate(scenario, variant.algorithm, options,  # type: ignore[arg-type]
                      refine=refine)
    elapsed = clock() - t0
    name = f"{variant.name} +refine" if refine else variant.name
    return RunRecord(experiment, name, n_agents, run, result.total_score,
                     result.comm_steps, result.messages, result.bytes, result.converged,
                     result.conflict_free, elapsed, result.pairwise_steps,
                     result.bytes_dense, cost, team_mode)
