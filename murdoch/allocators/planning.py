"""How a robot turns the live offers into a consensus problem (pure).

Path cost: straight-line distance at the robot's nominal speed, from where the robot is
when it plans (or, while it executes a task, from that task's place once its expected
duration has run out). A robot that does not move works where it stands (no travel). Every
offer scores ``REWARD * exp(-DISCOUNT * (start - offered_at))``: the sooner a task can start
after it was offered, the better. A robot may bid on an offer when the offer's subjects are
among its own (and its library has the task); for CBGA the robot's subjects are its
equipment and the offer's subjects the equipment the task needs. A group offer
(`group_offers`) needs `required` agents at once, each of them able to fill one of its seats:
a robot may bid on it when it can fill a seat, so the group's equipment is checked per seat
here, not as the union CBGA's scenarios allow.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from murdoch.allocators.group_offers import fillable, required
from murdoch.allocators.team_messages import TaskOffer
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.scoring import Problem, build_problem

REWARD = 100.0
DISCOUNT = 1.0 / 600.0
"""A task started ten minutes after it was offered is worth 1/e of one started at once."""
BUNDLE_LIMIT = 4
STILL_SPEED_MPS = 1e6
"""The travel speed that stands for "does not move"."""


@dataclass(frozen=True)
class Profile:
    """What an agent plans from: where it is (or will be), its speed, when it is free, the
    offers it may bid on and its subjects (its equipment)."""

    position: tuple[float, float]
    speed_mps: float
    available_at: float
    capable: frozenset[int]
    subjects: frozenset[str]


def capable_offers(offers: Sequence[TaskOffer], subjects: frozenset[str],
                   can_do: Mapping[str, bool]) -> frozenset[int]:
    """The offers a robot with these subjects and this library (task kind -> known) may
    bid on: those with a seat it can fill."""
    return frozenset(o.offer for o in offers
                     if fillable(o, subjects, lambda kind: can_do.get(kind, False)))


def team_problem(team: Sequence[str], profiles: Mapping[int, Profile],
                 offers: Sequence[TaskOffer]) -> Problem:
    """The problem over the offers in the given order (their local indices) for the agents
    of `team`: those in `profiles` as they describe themselves, the others only by index
    (nothing they may do)."""
    agents = []
    for n, name in enumerate(team):
        pr = profiles.get(n)
        if pr is not None:
            speed = pr.speed_mps if pr.speed_mps > 0 else STILL_SPEED_MPS
            agents.append(Agent(name, pr.position, speed,
                                frozenset(str(o) for o in pr.capable), pr.subjects,
                                pr.available_at))
        else:
            agents.append(Agent(name, (0.0, 0.0), 1.0, frozenset(), frozenset(), 0.0))
    tasks = [Task(str(o.offer), (o.x, o.y), str(o.offer), REWARD, DISCOUNT,
                  start_s=o.offered_at, end_s=math.inf, duration_s=max(0.0, o.duration_s),
                  agents_required=required(o),
                  equipment=frozenset(o.subjects) if required(o) == 1 else frozenset())
             for o in offers]
    return build_problem(Scenario("team", tuple(agents), tuple(tasks), time_windows=True,
                                  max_depth=BUNDLE_LIMIT, comm_graph=CommGraph()))


def plan_profile(offers: Sequence[TaskOffer], *, subjects: frozenset[str],
                 can_do: Mapping[str, bool], position: tuple[float, float], speed_mps: float,
                 available_at: float) -> Profile:
    return Profile(position, speed_mps, available_at,
                   capable_offers(offers, subjects, can_do), subjects)


def plan_problem(
    team: Sequence[str], index: int, offers: Sequence[TaskOffer], *,
    subjects: frozenset[str], can_do: Mapping[str, bool], position: tuple[float, float],
    speed_mps: float, available_at: float,
) -> Problem:
    """The problem agent `index` of `team` plans over: the offers in the given order (their
    local indices), its own position, speed and availability; the other agents appear only
    by index (their rows are never used by this agent's bundle building)."""
    profile = plan_profile(offers, subjects=subjects, can_do=can_do, position=position,
                           speed_mps=speed_mps, available_at=available_at)
    return team_problem(team, {index: profile}, offers)
