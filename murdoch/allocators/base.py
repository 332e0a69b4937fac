"""What an allocator is to the robots and to the runner: a pair of `TeamMember` factories.

An allocator (`Allocator`) builds the member a robot process runs (`robot`, from the
robot's `RobotHooks`: what it can do, where it is, how fast it goes, and the callbacks that
start and stop the task it is to execute next) and the member the runner runs as the user
(`user`, from `UserHooks`: where a task is), and names the message codec its team speaks.
The registry (`murdoch.allocators.ALLOCATORS`) maps names to allocators.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from murdoch.auction.messages import AuctionEvent, Outcome
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.user_agent import RandomizedBackoff
from murdoch.wire import Codec


@dataclass(frozen=True)
class Assignment:
    """A task a robot is to execute now (or stop executing)."""

    task_id: str
    name: str
    params: Mapping[str, Any]


@dataclass(frozen=True)
class RobotHooks:
    """What a robot's allocator member may ask of its robot (`behaviors.murdoch_link`)."""

    agent_id: str
    subjects: frozenset[str]
    score: Callable[[str, Mapping[str, Any], str], float | None]
    """(task name, parameters, task id) -> the robot's bid (MURDOCH's metric); None: no bid."""
    knows: Callable[[str], bool]
    """Whether the robot has a task of this name in its library."""
    on_start: Callable[[Assignment], None]
    on_stop: Callable[[Assignment, str], None]
    position: Callable[[], tuple[float, float]] = lambda: (0.0, 0.0)
    """Where the robot is now (metres, world frame)."""
    speed_mps: float = 0.5
    """Nominal travel speed; 0 for a robot that does not move (it works where it stands)."""
    team: tuple[str, ...] = ()
    """Every member of the team in a fixed order (the world's robots): consensus indices."""
    on_outcome: Callable[[Outcome], None] | None = None
    observer: Callable[[AuctionEvent], None] | None = None
    backoff: RandomizedBackoff | None = None
    pose: Callable[[], tuple[float, float, float]] | None = None
    """Where the robot is and which way it faces (x, y metres, yaw radians); None: the
    position and yaw 0."""
    battery: Callable[[], float | None] | None = None
    """State of charge, a fraction of full (None: unknown)."""


@dataclass(frozen=True)
class UserHooks:
    """What the runner's member (the user: task source and referee of contracts) needs."""

    agent_id: str
    observer: Callable[[AuctionEvent], None] | None
    backoff: RandomizedBackoff
    locate: Callable[[str, Mapping[str, Any]], tuple[float, float]] = lambda n, p: (0.0, 0.0)
    """Where a task of this name and these parameters is to be done (metres, world frame)."""


RobotFactory = Callable[[Transport, Clock, RobotHooks], TeamMember]
UserFactory = Callable[[Transport, Clock, UserHooks], TeamMember]


@dataclass(frozen=True)
class Allocator:
    """An allocator by name. Its parts are loaded when first used (`load_codec` and the
    factories import what they need), so naming every allocator costs a process nothing."""

    name: str
    summary: str
    load_codec: Callable[[], Codec]
    robot: RobotFactory
    user: UserFactory
    sub_tasks: bool
    """Whether a robot's member can introduce sub-tasks of its running task (boxpush)."""
    refined: Callable[[], Allocator] | None = None
    """The same allocator with the improvement phase on the robots (`--refine`); None when
    it has none (MURDOCH)."""
    refine: bool = False
    """Whether this is the refined form."""
    group_tasks: bool = False
    """Whether the team takes a task that needs several robots at once whole (its robots
    form the group, `murdoch.allocators.group_offers`); otherwise the runner's coordinator
    hands out its members as single-robot tasks."""

    @property
    def codec(self) -> Codec:
        """The codec of every message this allocator's team sends."""
        return self.load_codec()
