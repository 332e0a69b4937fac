"""The allocators a team can run, by name: `murdoch-robot --allocator NAME` and
`murdoch run ... --allocator NAME` take them from here.

`ALLOCATORS` is the registry (`murdoch.allocators.registry`): the built-ins (MURDOCH, CBBA,
CBGA and the `greedy` and `optimal` baselines) and every allocator an installed package
registers under the entry-point group `murdoch.allocators`. Writing one: `murdoch.plugin`.
"""

from __future__ import annotations

from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.allocators.registry import Registry

ALLOCATORS = Registry()
DEFAULT = "murdoch"


def refinable() -> tuple[str, ...]:
    """The allocators that take `--refine` (the consensus ones)."""
    return tuple(n for n, a in ALLOCATORS.items() if a.refined is not None)


def __getattr__(name: str) -> tuple[str, ...]:
    if name == "REFINABLE":  # (computed on use: the registry loads on first use)
        return refinable()
    raise AttributeError(name)


def allocator(name: str, refine: bool = False) -> Allocator:
    """The allocator called `name` (with `refine`, its refined form); ValueError naming the
    known ones, or those that take `--refine`, otherwise; `murdoch.plugin.PluginError` if
    an installed plugin is broken."""
    ALLOCATORS.check()
    try:
        found = ALLOCATORS[name]
    except KeyError:
        raise ValueError(f"unknown allocator {name!r} (expected one of "
                         f"{', '.join(ALLOCATORS)})") from None
    if not refine:
        return found
    if found.refined is None:
        raise ValueError(f"--refine is for the consensus allocators ({', '.join(refinable())}), "
                         f"not {name}")
    return found.refined()


__all__ = ["ALLOCATORS", "DEFAULT", "Allocator", "Assignment", "RobotHooks", "UserHooks",
           "allocator", "refinable"]
