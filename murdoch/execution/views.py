"""What a central allocator sees: frozen views of the open tasks, the robots and the world.

Built by the user's central member (`central_user`) from the tasks it holds and the robots'
status reports; handed to `murdoch.plugin.CentralAllocator`. Pure values: an allocator may
keep them, never change them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class TaskView:
    """An open task waiting for an executor."""

    id: str
    kind: str
    """The task's name in the robots' library (e.g. "visit", "inspect")."""
    place: tuple[float, float] | None
    """Where it is done (metres, world frame); None: anywhere."""
    subjects: frozenset[str]
    """The resource subjects (devices) an executor must offer."""
    arrived_s: float
    """When it was introduced (simulation seconds)."""
    params: Mapping[str, Any] = field(default_factory=dict)
    duration_s: float = 0.0
    attempt: int = 1

    @property
    def needs(self) -> frozenset[str]:
        """The same as `subjects`."""
        return self.subjects


@dataclass(frozen=True)
class RobotView:
    """A robot of the team as its latest status report described it."""

    name: str
    pose: tuple[float, float, float]
    """x, y (metres) and yaw (radians), world frame."""
    subjects: frozenset[str]
    """What it offers now; empty while it has left the team (charging)."""
    battery: float | None
    """State of charge as a fraction of full; None: unknown."""
    busy: str | None
    """The task it executes (None: free)."""
    speed_mps: float = 0.5

    @property
    def free(self) -> bool:
        """Whether it takes tasks now: it executes none and offers subjects."""
        return self.busy is None and bool(self.subjects)


@dataclass(frozen=True)
class WorldView:
    """The user's picture at one moment: time, open tasks (in arrival order), robots heard
    lately (by name)."""

    time_s: float
    tasks: tuple[TaskView, ...]
    robots: tuple[RobotView, ...]

    def capable(self, robot: RobotView, task: TaskView) -> bool:
        """Whether the robot offers every subject the task needs."""
        return task.subjects <= robot.subjects

    def candidates(self, task: TaskView) -> tuple[RobotView, ...]:
        """The free robots capable of the task."""
        return tuple(r for r in self.robots if r.free and self.capable(r, task))

    def distance(self, robot: RobotView, task: TaskView) -> float:
        """Straight-line distance from the robot to where the task is (0: anywhere)."""
        if task.place is None:
            return 0.0
        return math.hypot(task.place[0] - robot.pose[0], task.place[1] - robot.pose[1])

    def cost(self, robot: RobotView, task: TaskView) -> float:
        """The task's metric for this robot: seconds to reach it (lower is better; a robot
        that does not move works where it stands)."""
        if robot.speed_mps <= 0:
            return 0.0
        return self.distance(robot, task) / robot.speed_mps
