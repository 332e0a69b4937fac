"""CBGA: equals CBBA without group tasks; groups, equipment, replacement, prerequisites,
task quitting and team reward on hand-built cases; conflict-free on random group scenarios."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus import CbgaOptions, allocate
from murdoch.consensus.cbga import CbgaAgent
from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.scoring import build_problem

OFF = CbgaOptions(task_quitting=False, team_reward=False)


def _graph(rng: np.random.Generator, ids: list[str], kind: str) -> CommGraph:
    if kind == "full":
        return CommGraph()
    if kind == "line":
        return CommGraph(False, tuple(pairwise(ids)))
    order = rng.permutation(len(ids))
    edges = {(ids[order[n]], ids[order[int(rng.integers(0, n))]]) for n in range(1, len(ids))}
    edges |= {(ids[a], ids[b]) for a in range(len(ids)) for b in range(a + 1, len(ids))
              if rng.random() < 0.3}
    return CommGraph(False, tuple(sorted(edges)))


@settings(max_examples=20, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 10),
       st.sampled_from(["full", "line", "random"]), st.booleans())
def test_equals_cbba_on_single_agent_tasks(seed, n_agents, n_tasks, graph, quitting) -> None:
    rng = np.random.default_rng(seed)
    s = make_scenario("s", rng, [frozenset()] * n_agents, [TaskSpec()] * n_tasks)
    s = Scenario(s.name, s.agents, s.tasks, comm_graph=_graph(rng, [a.id for a in s.agents],
                                                             graph))
    a = allocate(s, "cbba")
    g = allocate(s, "cbga", CbgaOptions(task_quitting=quitting, team_reward=True))
    assert g.assignment == a.assignment
    assert g.total_score == a.total_score
    assert (g.comm_steps, g.messages, g.bytes) == (a.comm_steps, a.messages, a.bytes)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(st.integers(0, 10**6), st.integers(2, 6), st.integers(1, 8),
       st.sampled_from(["full", "line", "random"]), st.booleans(), st.booleans(),
       st.sampled_from(["plain", "typed", "prereq"]))
def test_group_scenarios_converge_conflict_free(seed, n_agents, n_tasks, graph, quitting,
                                                team, kind) -> None:
    rng = np.random.default_rng(seed)
    sizes = rng.integers(1, min(n_agents, 3) + 1, n_tasks)
    if kind == "typed":
        equipment = [frozenset({"AB"[i % 2]}) for i in range(n_agents)]
        specs = [TaskSpec(int(L), frozenset("AB"[: int(L)])) for L in sizes]
    elif kind == "prereq":
        equipment = [frozenset()] * n_agents
        specs = [TaskSpec(int(L), prerequisite=(j - 1 if j % 2 else None))
                 for j, L in enumerate(sizes)]
    else:
        equipment = [frozenset()] * n_agents
        specs = [TaskSpec(int(L)) for L in sizes]
    s = make_scenario("g", rng, equipment, specs, team_reward=team,
                      quit_after=3.0 if quitting else None)
    s = Scenario(s.name, s.agents, s.tasks, comm_graph=_graph(rng, [a.id for a in s.agents],
                                                             graph))
    r = allocate(s, "cbga", CbgaOptions(task_quitting=quitting, team_reward=team),
                 max_rounds=400)
    assert r.converged and r.conflict_free and r.agreed
    groups: dict[str, list[str]] = {}
    for a, ts in r.assignment.items():
        for t in ts:
            groups.setdefault(t, []).append(a)
    tasks = {t.id: t for t in s.tasks}
    for t, members in groups.items():
        assert len(members) <= tasks[t].agents_required


def _agents(*specs: tuple[str, tuple[float, float], frozenset[str]]) -> tuple[Agent, ...]:
    return tuple(Agent(i, p, equipment=e) for i, p, e in specs)


def test_two_agent_task_gets_both_agents_and_pays_each() -> None:
    agents = _agents(("a1", (0.0, 0.0), frozenset()), ("a2", (20.0, 0.0), frozenset()))
    tasks = (Task("lift", (5.0, 0.0), reward=100, discount=0.0, agents_required=2),)
    r = allocate(Scenario("pair", agents, tasks), "cbga", OFF)
    assert r.assignment == {"a1": ["lift"], "a2": ["lift"]}
    assert r.start_times == {"a1": [15.0], "a2": [15.0]}  # waits for a2 to arrive
    assert r.total_score == 200.0 and r.unassigned == []


def test_closest_agents_win_a_full_group() -> None:
    agents = _agents(("far", (40.0, 0.0), frozenset()), ("near", (1.0, 0.0), frozenset()),
                     ("mid", (10.0, 0.0), frozenset()))
    tasks = (Task("lift", (0.0, 0.0), reward=100, discount=0.05, agents_required=2),)
    r = allocate(Scenario("replace", agents, tasks), "cbga", OFF)
    assert r.assignment == {"far": [], "near": ["lift"], "mid": ["lift"]}


def test_group_must_cover_equipment_and_replaces_same_equipment_only() -> None:
    # two camera agents closer than the gripper agent: the group still takes the gripper
    agents = _agents(("cam1", (1.0, 0.0), frozenset({"camera"})),
                     ("cam2", (2.0, 0.0), frozenset({"camera"})),
                     ("grip", (30.0, 0.0), frozenset({"gripper"})))
    tasks = (Task("fetch", (0.0, 0.0), reward=100, discount=0.05, agents_required=2,
                  equipment=frozenset({"camera", "gripper"})),)
    r = allocate(Scenario("equip", agents, tasks), "cbga", OFF)
    assert r.assignment == {"cam1": ["fetch"], "cam2": [], "grip": ["fetch"]}
    assert r.unassigned == []


def test_single_agent_task_needs_all_its_equipment() -> None:
    agents = _agents(("cam", (0.0, 0.0), frozenset({"camera"})),
                     ("both", (50.0, 0.0), frozenset({"camera", "gripper"})))
    tasks = (Task("grab", (1.0, 0.0), reward=100, discount=0.01,
                  equipment=frozenset({"camera", "gripper"})),)
    for algorithm in ("cbba", "cbga"):
        r = allocate(Scenario("eq1", agents, tasks), algorithm, OFF)  # type: ignore[arg-type]
        assert r.assignment == {"cam": [], "both": ["grab"]}


def test_prerequisite_is_done_first_by_the_same_agent() -> None:
    agents = _agents(("a1", (0.0, 0.0), frozenset()))
    tasks = (Task("second", (2.0, 0.0), reward=100, prerequisites=("first",), duration_s=1),
             Task("first", (10.0, 0.0), reward=100, duration_s=5))
    r = allocate(Scenario("pre", agents, tasks), "cbga", OFF)
    assert r.assignment == {"a1": ["first", "second"]}
    first, second = r.start_times["a1"]
    assert second >= first + 5
    blocked = Scenario("pre2", (Agent("a1", (0.0, 0.0), capabilities=frozenset({"task"})),),
                       (Task("second", (2.0, 0.0), prerequisites=("first",)),
                        Task("first", (10.0, 0.0), type="other")))
    assert allocate(blocked, "cbga", OFF).assignment == {"a1": []}


def _stalled_scenario(quit_after: float | None) -> Scenario:
    # a three-agent task only two agents can do, and a solo task that clashes with it in time
    agents = (Agent("a1", (0.0, 0.0), capabilities=frozenset({"big", "small"})),
              Agent("a2", (1.0, 0.0), capabilities=frozenset({"big", "small"})),
              Agent("a3", (50.0, 50.0), capabilities=frozenset({"none"})))
    tasks = (Task("big", (2.0, 0.0), type="big", reward=300, start_s=10, end_s=10,
                  duration_s=50, agents_required=3, quit_after=quit_after),
             Task("small", (3.0, 0.0), type="small", reward=100, start_s=20, end_s=20,
                  duration_s=5))
    return Scenario("stall", agents, tasks)


def test_task_quitting_frees_agents_from_a_group_that_cannot_fill() -> None:
    stuck = allocate(_stalled_scenario(None), "cbga", CbgaOptions(True, False))
    assert stuck.assignment["a1"] == ["big"] and stuck.assignment["a2"] == ["big"]
    assert stuck.total_score == 0.0
    freed = allocate(_stalled_scenario(3.0), "cbga", CbgaOptions(True, False))
    assert freed.converged and freed.conflict_free
    assert freed.total_score == pytest.approx(100.0)
    assert "big" not in freed.assignment["a1"] + freed.assignment["a2"]
    assert freed.comm_steps > 3  # it waited out the threshold
    off = allocate(_stalled_scenario(3.0), "cbga", CbgaOptions(False, False))
    assert off.total_score == 0.0


def test_team_reward_raises_bids_on_partly_filled_groups() -> None:
    agents = _agents(("a1", (0.0, 0.0), frozenset()), ("a2", (5.0, 0.0), frozenset()),
                     ("a3", (9.0, 0.0), frozenset()))
    tasks = (Task("t", (1.0, 0.0), reward=100, discount=0.0, agents_required=3,
                  team_reward=60),)
    p = build_problem(Scenario("team", agents, tasks))
    plain = CbgaAgent(p, 1, CbgaOptions(False, False))
    team = CbgaAgent(p, 1, CbgaOptions(False, True))
    for a in (plain, team):
        a.x[0][0] = 100.0  # a1 already in the group
        a.build_bundle()
    assert plain.x[0][1] == pytest.approx(100.0)
    assert team.x[0][1] == pytest.approx(100.0 + 60 * 1 / 2)
    assert math.isfinite(team.x[0][1])
