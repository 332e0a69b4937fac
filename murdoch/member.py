"""What a team member's allocator offers its robot: the seam between a robot and allocation.

A robot (`behaviors.murdoch_link`) and the experiment runner see their allocator only through
`TeamMember`; `murdoch.node.Node` (MURDOCH auctions over the bus) implements it, and another
allocation scheme plugs in by implementing the same methods. The member:

- offers capabilities: the resource subjects it can serve (`subjects`, `set_subjects`);
  offering none leaves the team (e.g. to charge), offering them again rejoins it;
- hears tasks on `step` and introduces its own (`announce`, withdrawn with `cancel`; those
  still open are `open_tasks`);
- steps once per tick of its owner's loop (`step`), where it bids, awards and renews;
- says what to execute next through the `on_start`/`on_stop` callbacks it was built with,
  and which task that is now (`executing`);
- takes the executor's reports (`progress`, `complete`, `fail`, `abandon`).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol

from murdoch.auction.messages import TaskSpec
from murdoch.subjects import SubjectSet


class TeamMember(Protocol):
    # -- capabilities: offer, leave (none), rejoin
    @property
    def subjects(self) -> SubjectSet: ...

    def set_subjects(self, subjects: Iterable[str] | str) -> None: ...

    # -- tasks this member introduces
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str: ...

    def cancel(self, task_id: str, reason: str = "cancelled") -> None: ...

    def open_tasks(self) -> tuple[str, ...]: ...

    # -- the tick
    def step(self, timeout_s: float = 0.0) -> int: ...

    # -- what this member executes and its reports
    @property
    def executing(self) -> str | None: ...

    def progress(self, task_id: str, fraction: float, note: str = "") -> None: ...

    def complete(self, task_id: str, note: str = "") -> None: ...

    def fail(self, task_id: str, reason: str) -> None: ...

    def abandon(self, task_id: str, reason: str) -> None: ...

    def close(self) -> None: ...
