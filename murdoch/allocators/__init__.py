"""The allocators a team can run, by name: `murdoch-robot --allocator NAME` and
`murdoch run ... --allocator NAME` take them from here.

Adding one: a module of this package with an `Allocator` (`murdoch.allocators.base`: the
robot's and the user's `murdoch.member.TeamMember` factories and its message codec) and a
line in `ALLOCATORS`.
"""

from __future__ import annotations

from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.allocators.cbba import CBBA
from murdoch.allocators.cbga import CBGA
from murdoch.allocators.murdoch_auctions import MURDOCH

ALLOCATORS: dict[str, Allocator] = {
    "murdoch": MURDOCH,
    "cbba": CBBA,
    "cbga": CBGA,
}
DEFAULT = "murdoch"


REFINABLE: tuple[str, ...] = tuple(n for n, a in ALLOCATORS.items() if a.refined is not None)
"""The allocators that take `--refine` (the consensus ones)."""


def allocator(name: str, refine: bool = False) -> Allocator:
    """The allocator called `name` (with `refine`, its refined form); ValueError naming the
    known ones, or those that take `--refine`, otherwise."""
    try:
        found = ALLOCATORS[name]
    except KeyError:
        raise ValueError(f"unknown allocator {name!r} (expected one of "
                         f"{', '.join(ALLOCATORS)})") from None
    if not refine:
        return found
    if found.refined is None:
        raise ValueError(f"--refine is for the consensus allocators ({', '.join(REFINABLE)}), "
                         f"not {name}")
    return found.refined()


__all__ = ["ALLOCATORS", "DEFAULT", "REFINABLE", "Allocator", "Assignment", "RobotHooks",
           "UserHooks", "allocator"]
