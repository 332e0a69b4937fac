"""CPU affinity of the serving thread and of everything else in a run.

On a machine with few cores, the serving thread (which every lockstep client waits on) loses
much of its time to the robot processes when the scheduler lets them share its core. A run
can give that thread a core of its own and keep every other thread and process on the
others: `plan_split` chooses, `pin_current_thread` applies a set to the calling thread only
(Linux ``sched_setaffinity`` on thread id 0); threads and processes started afterwards
inherit it. Where affinity is not available (not Linux) nothing is pinned.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable
from dataclasses import dataclass

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CpuSplit:
    """The serving thread's CPUs and everyone else's (disjoint, both non-empty)."""

    serving: frozenset[int]
    others: frozenset[int]

    def as_dict(self) -> dict[str, list[int]]:
        return {"serving": sorted(self.serving), "others": sorted(self.others)}


def plan_split(allowed: Iterable[int]) -> CpuSplit | None:
    """The highest-numbered allowed CPU for the serving thread, the rest for the others;
    None with fewer than two CPUs (nothing to separate)."""
    cpus = sorted(set(allowed))
    if len(cpus) < 2:
        return None
    return CpuSplit(frozenset(cpus[-1:]), frozenset(cpus[:-1]))


def allowed_cpus() -> frozenset[int] | None:
    """The CPUs the calling thread may run on, or None where that cannot be known."""
    getter = getattr(os, "sched_getaffinity", None)
    if getter is None:
        return None
    try:
        return frozenset(getter(0))
    except OSError:
        return None


def pin_current_thread(cpus: Iterable[int]) -> bool:
    """Restrict the calling thread to `cpus`; False (logged) where that is not possible."""
    setter = getattr(os, "sched_setaffinity", None)
    if setter is None:
        return False
    try:
        setter(0, set(cpus))
    except (OSError, ValueError) as exc:
        log.warning("could not pin this thread to CPUs %s: %s", sorted(cpus), exc)
        return False
    return True
