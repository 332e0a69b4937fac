"""How a robot turns the live offers into a consensus problem (pure).

Path cost: straight-line distance at the robot's nominal speed, from where the robot is
when it plans (or, while it executes a task, from that task's place once its expected
duration has run out). A robot that does not move works where it stands (no travel). Every
offer scores ``REWARD * exp(-DISCOUNT * (start - offered_at))``: the sooner a task can start
after it was offered, the better. A robot may bid on an offer when the offer's subjects are
among its own (and its library has the task); for CBGA the robot's subjects are its
equipment and the offer's subjects the equipment the task needs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from murdoch.allocators.team_messages import TaskOffer
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.scoring import Problem, build_problem

REWARD = 100.0
DISCOUNT = 1.0 / 600.0
"""A task started ten minutes after it was offered is worth 1/e of one started at once."""
BUNDLE_LIMIT = 4
STILL_SPEED_MPS = 1e6
"""The travel speed that stands for "does not move"."""


def plan_problem(
    team: Sequence[str], index: int, offers: Sequence[TaskOffer], *,
    subjects: frozenset[str], can_do: Mapping[str, bool], position: tuple[float, float],
    speed_mps: float, available_at: float,
) -> Problem:
    """The problem agent `index` of `team` plans over: the offers in the given order (their
    local indices), its own position, speed and availability; the other agents appear only
    by index (their rows are never used by this agent's bundle building)."""
    capable = frozenset(
        str(o.offer) for o in offers
        if set(o.subjects) <= subjects and can_do.get(o.name, False))
    agents = []
    for n, name in enumerate(team):
        if n == index:
            speed = speed_mps if speed_mps > 0 else STILL_SPEED_MPS
            agents.append(Agent(name, position, speed, capable, subjects, available_at))
        else:
            agents.append(Agent(name, (0.0, 0.0), 1.0, frozenset(), frozenset(), 0.0))
    tasks = [Task(str(o.offer), (o.x, o.y), str(o.offer), REWARD, DISCOUNT,
                  start_s=o.offered_at, end_s=math.inf, duration_s=max(0.0, o.duration_s),
                  equipment=frozenset(o.subjects))
             for o in offers]
    return build_problem(Scenario("team", tuple(agents), tuple(tasks), time_windows=True,
                                  max_depth=BUNDLE_LIMIT, comm_graph=CommGraph()))
