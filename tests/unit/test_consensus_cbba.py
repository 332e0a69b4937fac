"""CBBA: conflict-free convergence on random scenarios and graphs, equality with sequential
greedy on diminishing-marginal-gain scenarios, outbid release and disconnected graphs."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus import SyncRunner, allocate, sequential_greedy
from murdoch.consensus.cbba import CbbaAgent
from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.scoring import build_problem


def random_connected_graph(rng: np.random.Generator, ids: list[str],
                           extra: float) -> CommGraph:
    order = rng.permutation(len(ids))
    edges = {(ids[order[n]], ids[order[int(rng.integers(0, n))]]) for n in range(1, len(ids))}
    for a in range(len(ids)):
        for b in range(a + 1, len(ids)):
            if rng.random() < extra:
                edges.add((ids[a], ids[b]))
    return CommGraph(False, tuple(sorted(edges)))


def random_scenario(seed: int, n_agents: int, n_tasks: int, graph: str,
                    max_depth: int | None = None) -> Scenario:
    rng = np.random.default_rng(seed)
    s = make_scenario("r", rng, [frozenset()] * n_agents, [TaskSpec()] * n_tasks)
    ids = [a.id for a in s.agents]
    if graph == "line":
        g = CommGraph(False, tuple(pairwise(ids)))
    elif graph == "random":
        g = random_connected_graph(rng, ids, 0.3)
    else:
        g = CommGraph()
    return Scenario(s.name, s.agents, s.tasks, True, max_depth, g)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 10),
       st.sampled_from(["full", "line", "random"]), st.sampled_from([None, 1, 2, 3]))
def test_converges_conflict_free_on_connected_graphs(seed, n_agents, n_tasks, graph,
                                                     depth) -> None:
    s = random_scenario(seed, n_agents, n_tasks, graph, depth)
    r = allocate(s, "cbba")
    assert r.converged and r.conflict_free and r.agreed
    won = [t for ts in r.assignment.values() for t in ts]
    assert len(won) == len(set(won))
    assert all(len(ts) <= (depth or n_tasks) for ts in r.assignment.values())
    assert sorted(won + r.unassigned) == sorted(t.id for t in s.tasks)
    # every start time fits its window
    tasks = {t.id: t for t in s.tasks}
    for a, ts in r.assignment.items():
        for t, start in zip(ts, r.start_times[a], strict=True):
            assert tasks[t].start_s - 1e-6 <= start <= tasks[t].end_s + 1e-6  # printed to 1 us


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 10),
       st.sampled_from(["full", "line", "random"]))
def test_single_task_bundles_equal_sequential_greedy(seed, n_agents, n_tasks, graph) -> None:
    """Bundles of one task: marginal gains cannot rise, so CBBA must equal SGA."""
    s = random_scenario(seed, n_agents, n_tasks, graph, max_depth=1)
    assert allocate(s, "cbba").assignment == sequential_greedy(s).assignment


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(1, 5), st.integers(1, 9), st.integers(1, 4),
       st.sampled_from(["full", "line", "random"]))
def test_constant_rewards_equal_sequential_greedy(seed, n_agents, n_tasks, depth,
                                                  graph) -> None:
    """No discount, no windows: each task is worth its reward to whoever may do it (a
    diminishing-marginal-gain score), with random capabilities and bundle limits."""
    rng = np.random.default_rng(seed)
    types = ["a", "b", "c"]
    agents = tuple(Agent(f"a{i}", tuple(rng.uniform(0, 10, 2)),
                         capabilities=frozenset(rng.choice(types, 2, replace=False).tolist()))
                   for i in range(n_agents))
    tasks = tuple(Task(f"t{j}", tuple(rng.uniform(0, 10, 2)), type=str(rng.choice(types)),
                       reward=float(rng.integers(1, 50)), duration_s=1.0)
                  for j in range(n_tasks))
    base = random_scenario(seed, n_agents, 1, graph)
    s = Scenario("dmg", agents, tasks, time_windows=False, max_depth=depth,
                 comm_graph=_renamed(base.comm_graph, n_agents))
    assert allocate(s, "cbba").assignment == sequential_greedy(s).assignment


def _renamed(g: CommGraph, n: int) -> CommGraph:
    if g.edges is None:
        return g
    ren = {f"a{i + 1}": f"a{i}" for i in range(n)}
    return CommGraph(g.directed, tuple((ren[a], ren[b]) for a, b in g.edges))


def test_disconnected_graph_still_terminates() -> None:
    s = random_scenario(5, 4, 8, "full")
    split = Scenario(s.name, s.agents, s.tasks, comm_graph=CommGraph(False, (("a1", "a2"),
                                                                            ("a3", "a4"))))
    r = allocate(split, "cbba")
    assert r.converged
    # each island agrees internally even though the islands may claim the same task
    assert r.agreed


def test_outbid_task_and_later_ones_are_released() -> None:
    agents = (Agent("a", (0.0, 0.0)), Agent("b", (9.0, 0.0)))
    tasks = (Task("t1", (10.0, 0.0), reward=100, discount=0.1),
             Task("t2", (20.0, 0.0), reward=100, discount=0.1))
    p = build_problem(Scenario("r", agents, tasks))
    a = CbbaAgent(p, 0)
    a.build_bundle()
    assert a.bundle == [0, 1] and a.path == [0, 1]
    b = CbbaAgent(p, 1)
    b.build_bundle()
    msg = b.message(now=1.0)
    a.receive(msg, now=1.0)  # b's bids are higher on both tasks (it is closer)
    assert a.release_outbid()
    assert a.bundle == [] and a.path == []
    # the outbid task keeps its new winner; tasks added after it are reset (Choi et al.)
    assert a.z == [1, -1]


def test_runs_are_deterministic() -> None:
    s = random_scenario(11, 5, 12, "random")
    assert allocate(s, "cbba") == allocate(s, "cbba")


def test_counts_messages_and_bytes() -> None:
    s = random_scenario(3, 4, 8, "line")
    runner = SyncRunner(s, "cbba")
    r = runner.run()
    assert r.comm_steps >= 1
    assert r.messages == 6 * r.comm_steps  # a line of 4 has 3 links, both directions
    assert r.bytes > r.messages * 15
