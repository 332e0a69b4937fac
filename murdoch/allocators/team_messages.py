"""The messages CBBA and CBGA teams exchange on the bus besides their consensus state.

The user (the runner, as the task source) offers each task as an *offer*: a number that
names one attempt to allocate the task (`TaskOffer.offer`; a task re-offered after a
reallocation or a round without a winner gets a new number). Agents plan over the live
offers. The agent at the head of whose path an offer stands, and who wins it in its
consensus view, claims it (`TaskClaim`); the user grants each offer to the first claim it
acts on (`TaskGrant`), so no task is ever executed by two robots at once, and withdraws
offers that ended (`TaskWithdraw`: granted elsewhere, no winner, revoked, ended). The
executor reports progress and the end (`TaskReport`). Robots running with `--refine` also
exchange `TeamRefine` while they improve a settled plan. Agents' consensus state travels as
`murdoch.consensus.async_runner.ConsensusChunk`, entries naming offers, agents by their
index in the team (the world's robot order). A group offer (CBGA: one task for several
robots at once, `group_offers`) is claimed by each member of the full group (`SeatClaim`) and
granted seat by seat (`SeatGrant`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from murdoch.auction.messages import AUCTION_CODEC
from murdoch.consensus.async_runner import ConsensusChunk

TEAM_SUBJECT = "team.tasks"
"""Offers, grants and withdrawals: every agent and the user listen."""
STATE_SUBJECT = "team.state"
"""Consensus state, claims and reports."""
SESSION = "team"


@dataclass(frozen=True)
class OfferMessage:
    """What every message about an offer starts with: the task and the offer's number."""

    task_id: str
    offer: int


@dataclass(frozen=True)
class RobotOfferMessage(OfferMessage):
    """A message about an offer that names the robot it comes from or goes to."""

    robot: str


@dataclass(frozen=True)
class TaskOffer(OfferMessage):
    KIND: ClassVar[str] = "team-offer"
    name: str
    subjects: tuple[str, ...]
    params: Mapping[str, Any]
    duration_s: float
    x: float
    y: float
    offered_at: float


@dataclass(frozen=True)
class TaskClaim(RobotOfferMessage):
    KIND: ClassVar[str] = "team-claim"
    REPLY: ClassVar[bool] = True
    bid: float


@dataclass(frozen=True)
class SeatClaim(TaskClaim):
    """A claim of a group offer (`group_offers`): the seats this robot can fill and where
    it stands, from which the user hands out the seats."""

    KIND: ClassVar[str] = "team-seat-claim"
    seats: tuple[int, ...] = ()
    x: float = 0.0
    y: float = 0.0


@dataclass(frozen=True)
class TaskGrant(RobotOfferMessage):
    KIND: ClassVar[str] = "team-grant"


@dataclass(frozen=True)
class SeatGrant(TaskGrant):
    """A grant of one seat of a group offer: the robot runs that seat's task."""

    KIND: ClassVar[str] = "team-seat-grant"
    seat: int = 0


@dataclass(frozen=True)
class TaskWithdraw(OfferMessage):
    KIND: ClassVar[str] = "team-withdraw"
    reason: str


@dataclass(frozen=True)
class TaskReport(RobotOfferMessage):
    KIND: ClassVar[str] = "team-report"
    REPLY: ClassVar[bool] = True
    status: str
    """progress, completed, failed or abandoned"""
    fraction: float = 0.0
    reason: str = ""


@dataclass(frozen=True)
class TeamRefine:
    """Part of one robot's state in a `--refine` phase (`consensus_refine`): the snapshot it
    refines (the offers, ascending, and the agents taking part, by team index, ascending),
    how it plans (its `planning.Profile`: position, speed, when it is free, the offers it may
    do, its subjects) and its consensus path (offers), then the phase's entries as
    `murdoch.consensus.async_refine.RefineChunk` carries them, agents and tasks by their
    place in `members` and `offers`."""

    KIND: ClassVar[str] = "team-refine"
    sender: int
    offers: tuple[int, ...]
    members: tuple[int, ...]
    x: float
    y: float
    speed_mps: float
    available_at: float
    capable: tuple[int, ...]
    subjects: tuple[str, ...]
    path: tuple[int, ...]
    step: int
    entries: tuple[tuple[int, int, float, tuple[int, ...]], ...]
    previous_step: int
    previous: tuple[tuple[int, int, float, tuple[int, ...]], ...]


TEAM_KINDS = (TaskOffer, TaskClaim, SeatClaim, TaskGrant, SeatGrant, TaskWithdraw, TaskReport,
              ConsensusChunk, TeamRefine)
TEAM_CODEC = AUCTION_CODEC.extended(TEAM_KINDS)
"""Every message a CBBA or CBGA team sends (the auction kinds too, so tools that listen to
a bus understand both)."""
