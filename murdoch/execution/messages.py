"""The message a centrally allocated team adds to the team messages: a robot's status.

The user's central member grants and renews with `TaskOrder` (a `TaskGrant` carrying the
task), withdraws with `TaskWithdraw` and hears `TaskReport`s
(`murdoch.allocators.team_messages`); each robot says what it is and offers with
`RobotStatus` when that changes and every heartbeat (its liveness).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from murdoch.allocators.team_messages import TEAM_CODEC, TaskGrant


@dataclass(frozen=True)
class RobotStatus:
    KIND: ClassVar[str] = "team-robot-status"
    REPLY: ClassVar[bool] = True
    robot: str
    subjects: tuple[str, ...]
    x: float
    y: float
    yaw: float
    busy: str
    """The task id it executes; empty: none."""
    battery: float
    """Fraction of full; negative: unknown."""
    speed_mps: float


@dataclass(frozen=True)
class TaskOrder(TaskGrant):
    """A grant that carries the task (the robot has heard no offer): sent at the grant and
    repeated as the renewal."""

    KIND: ClassVar[str] = "team-order"
    name: str = ""
    params: Mapping[str, Any] = field(default_factory=dict)


CENTRAL_CODEC = TEAM_CODEC.extended((RobotStatus, TaskOrder))
"""Every message of a centrally allocated team."""
