"""A centralised allocator: one decision hook, and the team allocator that runs it.

`CentralAllocator` is what `murdoch.plugin` offers a user; `central_allocator` wraps a
subclass into an `Allocator` whose user member (`central_user.CentralUser`) asks the hook
and whose robots run the generic `central_robot.CentralRobot`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

from murdoch.allocators.base import Allocator, RobotHooks, UserHooks
from murdoch.execution.views import RobotView, TaskView, WorldView
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.wire import Codec


class CentralAllocator:
    """A centralised allocator: one decision hook, no robot-side code.

    Override `choose` (the default `assign` asks it for each open task in arrival order, each
    robot chosen at most once per decision) or, for a joint decision, `assign` itself."""

    name: ClassVar[str] = ""
    """Its registry name (`murdoch run --allocator NAME`): lowercase letters, digits, '-'."""
    summary: ClassVar[str] = ""
    """One line for `--help`."""

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        """The robot (by name, one of `candidates`: free, capable, not yet chosen in this
        decision) to execute `task`, or None to leave it open for now."""
        raise NotImplementedError(f"{type(self).__name__} overrides neither choose nor assign")

    def assign(self, world: WorldView) -> Mapping[str, str]:
        """The executors of open tasks (task id -> robot name): free, capable robots, each at
        most once. A task left out stays open (after its bid window without an executor it
        is retried with backoff, then unachievable)."""
        chosen: dict[str, str] = {}
        for task in world.tasks:
            taken = set(chosen.values())
            candidates = [r for r in world.candidates(task) if r.name not in taken]
            if candidates:
                robot = self.choose(task, candidates, world)
                if robot is not None:
                    chosen[task.id] = robot
        return chosen


def _central_codec() -> Codec:
    from murdoch.execution.messages import CENTRAL_CODEC

    return CENTRAL_CODEC


def central_allocator(cls: type[CentralAllocator]) -> Allocator:
    """The team allocator that runs `cls`'s decisions (one instance per run, on the user's
    side) over the generic robot member."""

    def robot(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
        from murdoch.execution.central_robot import CentralRobot

        return CentralRobot(transport, clock, hooks)

    def user(transport: Transport, clock: Clock, hooks: UserHooks) -> TeamMember:
        from murdoch.execution.central_user import CentralUser

        return CentralUser(transport, clock, hooks, cls().assign)

    return Allocator(cls.name, cls.summary or (cls.__doc__ or cls.name).strip().splitlines()[0],
                     _central_codec, robot, user, sub_tasks=False)
