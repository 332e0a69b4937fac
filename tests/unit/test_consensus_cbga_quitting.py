"""CBGA task quitting terminates: an agent that quit a group task stays out until it sees
more agents in the group than when it left, and after `quit_limit` quits of the same task it
gives the task up for the run, so quits are finite and a run cannot quit and rejoin for ever.

The seeded runs below used to cycle until the round limit: pairs of agents quitting two
stalled four-agent tasks in the same round and swapping them (each saw the other pair's
task as partly filled, from news one round old), or agents quitting, joining another group
by outbidding its members, and the displaced members joining the emptied task.
"""

from __future__ import annotations

import pytest

from murdoch.consensus import CbgaOptions
from murdoch.consensus.cbga import CbgaAgent
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.scenario import Agent, Scenario, Task
from murdoch.consensus.scoring import build_problem
from murdoch.consensus.sync_runner import allocate

QUITTING = CbgaOptions(task_quitting=True, team_reward=False)


def _one_group_task() -> CbgaAgent:
    # four agents side by side, one four-agent task (open window) with a 2-round threshold
    agents = tuple(Agent(f"a{n + 1}", (float(n), 0.0)) for n in range(4))
    tasks = (Task("g", (2.0, 5.0), reward=100, discount=0.0, agents_required=4,
                  quit_after=2.0),)
    return CbgaAgent(build_problem(Scenario("quit", agents, tasks)), 0, QUITTING)


def _members(agent: CbgaAgent, *others: int) -> None:
    """What agent 0 believes: these other agents (and no one else) hold task 0."""
    row = agent.x[0]
    for m in range(1, len(row)):
        row[m] = 50.0 if m in others else 0.0
    agent.needs_build = True


def test_a_quit_task_is_rejoined_only_once_others_have_joined() -> None:
    a = _one_group_task()
    _members(a, 1)
    a.build_bundle(now=1.0)
    assert a.bundle == [0]
    assert not a.quit_stalled(2.0)  # threshold not reached yet
    assert a.quit_stalled(3.0)  # alone with one partner after 2 rounds: quit
    assert a.bundle == [] and a.x[0][0] == 0.0 and a.banned[0] == 1 and a.quits[0] == 1
    a.build_bundle(now=4.0)
    assert a.bundle == []  # the same group: no reason to come back
    _members(a, 1, 2)
    a.build_bundle(now=5.0)
    assert a.bundle == [0]  # another agent joined since: rejoin
    assert a.banned[0] == -1
    _members(a, 1, 2, 3)
    assert a.complete(0) and not a.quit_stalled(20.0)  # a full group is never quit


def test_after_quit_limit_quits_a_task_is_given_up() -> None:
    a = _one_group_task()
    limit = a.options.quit_limit
    now = 0.0
    for n in range(1, limit + 1):
        _members(a, 1, 2)  # the group looks promising ...
        now += 1.0
        a.build_bundle(now)
        assert a.bundle == [0], n
        _members(a, 1)  # ... and stalls
        now += 2.0
        assert a.quit_stalled(now)
        assert a.quits[0] == n
    _members(a, 1, 2, 3)  # even a group this agent would complete
    a.build_bundle(now + 1.0)
    assert a.bundle == []


FORMERLY_CYCLING = [
    ("fig7", 1, 4, 11),  # two pairs quit two stalled tasks together and swapped them
    ("fig7", 3, 4, 42),
    ("fig7", 1, 7, 6),  # quits and rejoins across many partly filled tasks
    ("fig7", 3, 7, 14),
    ("fig7", 1, 8, 29),
    ("fig7", 3, 6, 66),
    ("fig7", 1, 10, 69),  # quit, joined the other group by outbidding, displaced rejoined
    ("fig7", 3, 10, 58),
]


@pytest.mark.parametrize(("experiment", "variant", "agents", "seed_run"), FORMERLY_CYCLING)
def test_formerly_cycling_quitting_runs_converge(experiment: str, variant: int, agents: int,
                                                 seed_run: int) -> None:
    v = EXPERIMENTS[experiment][variant]
    assert v.options.task_quitting
    result = allocate(v.make(agents, run_seed(0, agents, seed_run)), "cbga", v.options,
                      max_rounds=300)
    assert result.converged
    assert result.conflict_free
