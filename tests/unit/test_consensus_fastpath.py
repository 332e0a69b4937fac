"""The compiled synchronous CBBA run equals the agent-based one.

`allocate(..., "cbba")` runs the compiled kernel when it can; the agents of `SyncRunner` are
the reference. Both must give the same assignment, start times, score (bit for bit),
comm_steps, messages, bytes, rounds and convergence flags: on the recorded experiment
scenarios and on several hundred random scenarios with features the experiments do not use
(sparse, directed and disconnected graphs, bundle limits, capabilities, equipment, open
windows, no windows, late availability, prerequisites, integer geometry full of exact ties,
round limits).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from murdoch.consensus.cbba_fast import compiled_cbba_unsupported, load_compiled_cbba
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.sync_runner import AllocationResult, allocate

pytest.importorskip("numba")

COMPARED = [f.name for f in dataclasses.fields(AllocationResult) if f.name != "extra"]


def both(s: Scenario, max_rounds: int = 1000) -> tuple[AllocationResult, AllocationResult]:
    fast = allocate(s, "cbba", max_rounds=max_rounds)
    ref = allocate(s, "cbba", max_rounds=max_rounds, compiled=False)
    assert fast.extra["engine"] == "compiled"
    assert ref.extra["engine"] == "agents"
    return fast, ref


def assert_same(fast: AllocationResult, ref: AllocationResult, label: str) -> None:
    for name in COMPARED:
        assert getattr(fast, name) == getattr(ref, name), (label, name)


def random_scenario(rng: np.random.Generator, label: str) -> tuple[Scenario, int]:
    """A random CBBA scenario and a round limit (mostly generous, sometimes too short)."""
    n = int(rng.integers(1, 9))
    m = int(rng.integers(1, 16))
    dim = int(rng.choice([2, 3]))
    grid = rng.random() < 0.35  # integer geometry and speeds: many exactly equal bids
    time_windows = rng.random() < 0.8
    with_prereqs = rng.random() < 0.25  # tasks needing earlier tasks on the same path
    types = ("a", "b")
    items = ("cam", "arm")

    def point() -> tuple[float, ...]:
        if grid:
            return tuple(float(v) for v in rng.integers(0, 6, dim))
        return tuple(float(v) for v in rng.uniform(0, 100, dim))

    agents = []
    for i in range(n):
        caps = None
        if rng.random() < 0.2:
            caps = frozenset(t for t in types if rng.random() < 0.6)
        equipment = frozenset(e for e in items if rng.random() < 0.7)
        agents.append(Agent(
            id=f"a{i}", pos=point(),
            speed_mps=float(rng.integers(1, 4)) if grid else float(rng.uniform(0.5, 3.0)),
            capabilities=caps, equipment=equipment,
            availability_s=0.0 if rng.random() < 0.7 else float(rng.uniform(0, 60))))
    tasks = []
    for j in range(m):
        start = float(rng.integers(0, 40)) if grid else float(rng.uniform(0, 150))
        open_end = rng.random() < 0.2
        end = math.inf if open_end else start + (
            float(rng.integers(0, 30)) if grid else float(rng.uniform(0, 60)))
        discount = 0.0 if rng.random() < 0.2 else (
            0.05 if grid else float(rng.uniform(0.001, 0.1)))
        equipment = frozenset(e for e in items if rng.random() < 0.15)
        prereqs: tuple[str, ...] = ()
        if with_prereqs and j > 0 and rng.random() < 0.4:
            prereqs = tuple(sorted({f"t{int(q)}" for q in rng.integers(0, j, 2)}))
        tasks.append(Task(
            id=f"t{j}", pos=point(), type=str(rng.choice(types)),
            reward=100.0 if grid or rng.random() < 0.5 else float(rng.uniform(10, 200)),
            discount=discount, start_s=start, end_s=end,
            duration_s=float(rng.integers(0, 8)) if grid else float(rng.uniform(0, 15)),
            equipment=equipment, prerequisites=prereqs))
    ids = [a.id for a in agents]
    kind = rng.choice(["full", "sparse", "directed", "none"])
    if kind == "full":
        graph = CommGraph()
    elif kind == "none":
        graph = CommGraph(False, ())
    else:
        p_edge = float(rng.uniform(0.1, 0.6))
        edges = tuple((ids[a], ids[b]) for a in range(n) for b in range(n)
                      if a != b and (kind == "directed" or a < b) and rng.random() < p_edge)
        graph = CommGraph(kind == "directed", edges)
    depth = None if rng.random() < 0.6 else int(rng.integers(0, 5))
    rounds = 1000 if rng.random() < 0.9 else int(rng.integers(1, 6))
    s = Scenario(label, tuple(agents), tuple(tasks), time_windows, depth, graph)
    return s, rounds


@pytest.mark.parametrize(("variant", "agents", "run"),
                         [(0, a, r) for a in (3, 6, 10) for r in range(3)])
def test_recorded_experiments_identical(variant: int, agents: int, run: int) -> None:
    v = EXPERIMENTS["fig5"][variant]
    s = v.make(agents, run_seed(0, agents, run))
    fast, ref = both(s)
    assert_same(fast, ref, f"fig5/{agents}/{run}")


@pytest.mark.parametrize("block", range(6))
def test_random_scenarios_identical(block: int) -> None:
    """6 x 60 seeded random scenarios."""
    for n in range(60):
        seed = 1000 * block + n
        s, rounds = random_scenario(np.random.default_rng(seed), f"r{seed}")
        assert compiled_cbba_unsupported(s) is None
        fast, ref = both(s, rounds)
        assert_same(fast, ref, f"seed {seed}")


def test_bench_scenarios_identical() -> None:
    """The benchmark's 10-agent scenarios (seeds 0..19)."""
    v = EXPERIMENTS["fig5"][0]
    for seed in range(20):
        fast, ref = both(v.make(10, run_seed(0, 10, seed)))
        assert_same(fast, ref, f"bench {seed}")


def test_prerequisites_run_compiled() -> None:
    agents = (Agent("a0", (0.0, 0.0)), Agent("a1", (5.0, 0.0)))
    tasks = (Task("t0", (1.0, 0.0), discount=0.1), Task("t1", (2.0, 0.0), discount=0.1,
                                                        prerequisites=("t0",)))
    fast, ref = both(Scenario("pre", agents, tasks, time_windows=False))
    assert_same(fast, ref, "pre")
    assert fast.assignment == {"a0": ["t0", "t1"], "a1": []}


def test_negative_discount_falls_back_to_agents() -> None:
    agents = (Agent("a0", (0.0, 0.0)), Agent("a1", (5.0, 0.0)))
    tasks = (Task("t0", (1.0, 0.0), discount=-0.01), Task("t1", (2.0, 0.0), discount=0.1))
    s = Scenario("rising", agents, tasks, time_windows=False)
    note = compiled_cbba_unsupported(s)
    assert note is not None and note.startswith("negative discount")
    r = allocate(s, "cbba")
    assert r.extra == {"engine": "agents", "engine_note": note}
    assert r.conflict_free and r.converged
    assert r == dataclasses.replace(allocate(s, "cbba", compiled=False), extra=r.extra)


def test_group_tasks_still_rejected() -> None:
    s = Scenario("g", (Agent("a0", (0.0, 0.0)), Agent("a1", (1.0, 0.0))),
                 (Task("t0", (1.0, 1.0), agents_required=2),))
    assert compiled_cbba_unsupported(s) is not None
    with pytest.raises(ValueError, match="single-agent"):
        allocate(s, "cbba")


def test_kernel_loads() -> None:
    assert load_compiled_cbba()


@pytest.mark.parametrize("block", range(3))
def test_random_scenarios_identical_with_the_paper_cost(block: int) -> None:
    """3 x 60 seeded random scenarios scored with the paper's linear cost (negative scores
    included: far tasks, long durations, open windows)."""
    for n in range(60):
        seed = 50_000 + 1000 * block + n
        s, rounds = random_scenario(np.random.default_rng(seed), f"p{seed}")
        s = dataclasses.replace(s, cost="paper")
        assert compiled_cbba_unsupported(s) is None
        fast, ref = both(s, rounds)
        assert_same(fast, ref, f"seed {seed}")


def test_fig5_identical_with_the_paper_cost() -> None:
    v = EXPERIMENTS["fig5"][0]
    for agents in (3, 6, 10):
        s = dataclasses.replace(v.make(agents, run_seed(0, agents, 0)), cost="paper")
        fast, ref = both(s)
        assert_same(fast, ref, f"fig5/{agents}")
        assert fast.pairwise_steps <= fast.messages
