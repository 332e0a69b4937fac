"""The public allocator API: write a task allocator for a murdoch team, and check it.

Stable (kept compatible across minor versions; everything else in `murdoch` may change):

- `CentralAllocator`: subclass it, set `name` and override `choose` (one decision per open
  task) or `assign` (one joint decision over all open tasks). That is all a centralised
  allocator needs: the robots run a generic member (`murdoch.execution.central_robot`) and
  the team-member contract (grants, renewals, progress, revocation of a silent robot,
  backoff, `unachievable`; `murdoch.execution`) is kept for it.
- `TaskView`, `RobotView`, `WorldView`: what a decision sees (frozen values).
- `Allocator`, `RobotHooks`, `UserHooks`, `Assignment`: a *distributed* allocator, whose
  robots run code of its own (`murdoch.allocators.base`; MURDOCH, CBBA and CBGA are built so,
  on the same execution layer).
- `check_allocator(allocator)`: drives an allocator through a short scripted team and
  raises `ContractError` naming the rule it breaks.
- `PluginError`: a plugin that cannot be loaded or registered (one line).

Registering: the entry-point group `murdoch.allocators` (`name = "pkg.module:ClassName"`, a
`CentralAllocator` subclass or an `Allocator` instance); `murdoch.allocators.ALLOCATORS`
holds the built-ins and every installed plugin.

A decision hook is called (on the user's side, in the runner) whenever something changes
that could change a decision: a task arrives or is put up again, a robot frees up, fails,
leaves to charge or comes back. It must be deterministic (no clocks, no global random
numbers: a seeded run is replayed byte for byte) and quick (it runs inside the team's tick).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.execution.views import RobotView, TaskView, WorldView
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.wire import Codec


class PluginError(Exception):
    """An allocator plugin that cannot be used; its message is one line naming it."""


class ContractError(AssertionError):
    """An allocator broke a rule of the contract; the message names the rule."""


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


def check_allocator(allocator: Allocator | type[CentralAllocator] | str) -> None:
    """Drive `allocator` (or the registered one of that name) through the scripted team of
    `murdoch.execution.contract_check`; `ContractError` names the first rule it breaks."""
    from murdoch.execution.contract_check import run_contract_check

    if isinstance(allocator, str):
        from murdoch.allocators import allocator as named

        allocator = named(allocator)
    if isinstance(allocator, type):
        allocator = central_allocator(allocator)
    run_contract_check(allocator)


__all__ = ["Allocator", "Assignment", "CentralAllocator", "ContractError", "PluginError",
           "RobotHooks", "RobotView", "TaskView", "UserHooks", "WorldView", "central_allocator",
           "check_allocator"]
