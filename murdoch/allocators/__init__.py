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


def allocator(name: str) -> Allocator:
    """The allocator called `name`; ValueError naming the known ones otherwise."""
    try:
        return ALLOCATORS[name]
    except KeyError:
        raise ValueError(f"unknown allocator {name!r} (expected one of "
                         f"{', '.join(ALLOCATORS)})") from None


__all__ = ["ALLOCATORS", "DEFAULT", "Allocator", "Assignment", "RobotHooks", "UserHooks",
           "allocator"]
