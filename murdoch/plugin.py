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

from murdoch.allocators import allocator as _named
from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.allocators.registry import PluginError
from murdoch.execution.central import CentralAllocator, central_allocator
from murdoch.execution.contract_check import ContractError, run_contract_check
from murdoch.execution.views import RobotView, TaskView, WorldView


def check_allocator(allocator: Allocator | type[CentralAllocator] | str) -> None:
    """Drive `allocator` (or the registered one of that name) through the scripted team of
    `murdoch.execution.contract_check`; `ContractError` names the first rule it breaks."""
    if isinstance(allocator, str):
        allocator = _named(allocator)
    if isinstance(allocator, type):
        allocator = central_allocator(allocator)
    run_contract_check(allocator)


__all__ = ["Allocator", "Assignment", "CentralAllocator", "ContractError", "PluginError",
           "RobotHooks", "RobotView", "TaskView", "UserHooks", "WorldView", "central_allocator",
           "check_allocator"]
