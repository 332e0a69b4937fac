"""Seeded small allocation problems of several shapes, for measuring distance to the optimum.

Shapes: tasks spread uniformly or in clusters, time windows tight (10-30 s to start) or
loose (60 s to open), and a mixed shape with two task types and agents that can do only
some of them. Agents have mixed speeds (0.5-2 m/s) and some become available late. With
`groups`, about a third of the tasks need two agents whose equipment covers one or two
items (agents carry one of ``lift``/``cam``); group problems are CBGA's, the others CBBA's.
"""

from __future__ import annotations

import numpy as np

from murdoch.consensus.scenario import Agent, Scenario, Task

SHAPES = ("uniform-loose", "uniform-tight", "clustered-loose", "clustered-tight", "mixed")
_AREA = 60.0
_ITEMS = ("lift", "cam")


def small_problem(rng: np.random.Generator, n_agents: int, n_tasks: int, shape: str,
                  groups: bool = False, name: str = "small") -> Scenario:
    """One problem of the given shape (see the module text), drawn from `rng`."""
    if shape not in SHAPES:
        raise ValueError(f"unknown shape {shape!r} (expected one of {', '.join(SHAPES)})")
    tight = shape.endswith("tight")
    mixed = shape == "mixed"
    if shape.startswith("clustered"):
        centres = rng.uniform(0, _AREA, size=(int(rng.integers(2, 4)), 2))
        which = rng.integers(0, len(centres), size=n_tasks)
        task_pos = centres[which] + rng.normal(0, 4.0, size=(n_tasks, 2))
    else:
        task_pos = rng.uniform(0, _AREA, size=(n_tasks, 2))
    agents = []
    for i in range(n_agents):
        caps = None
        if mixed:
            caps = frozenset(("a", "b")[: int(rng.integers(1, 3))] if rng.random() < 0.5
                             else ("b",) if rng.random() < 0.5 else ("a", "b"))
        agents.append(Agent(
            id=f"a{i}", pos=tuple(float(v) for v in rng.uniform(0, _AREA, size=2)),
            speed_mps=float(rng.choice([0.5, 1.0, 1.0, 2.0])),
            capabilities=caps,
            equipment=frozenset((_ITEMS[i % 2],)) if groups else frozenset(),
            availability_s=float(rng.choice([0.0, 0.0, 0.0, 20.0]))))
    tasks = []
    n_group = (n_tasks + 1) // 3 if groups and n_agents >= 2 else 0
    for j in range(n_tasks):
        start = float(rng.uniform(0, 60))
        width = float(rng.uniform(10, 30)) if tight else float(rng.uniform(60, 120))
        group = j < n_group
        equipment: frozenset[str] = frozenset()
        if group:
            equipment = frozenset(_ITEMS[: int(rng.integers(1, 3))])
        tasks.append(Task(
            id=f"t{j}", pos=tuple(float(v) for v in task_pos[j]),
            type=str(rng.choice(["a", "b"])) if mixed else "task",
            reward=float(rng.choice([50.0, 100.0, 150.0])),
            discount=float(rng.uniform(0.005, 0.05)),
            start_s=start, end_s=start + width,
            duration_s=float(rng.uniform(0, 10)),
            agents_required=2 if group else 1,
            equipment=equipment))
    max_depth = int(rng.integers(2, 4)) if rng.random() < 0.25 else None
    return Scenario(name=name, agents=tuple(agents), tasks=tuple(tasks), time_windows=True,
                    max_depth=max_depth)
