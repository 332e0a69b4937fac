"""The executor's rules of the team-member contract (pure): hold, report, give up, resend.

A robot executing a granted task holds an `Execution`: it hears the grant repeated
(`renewed`) and reports progress, either each `progress_period_s` (`tick` says when) or in
answer to each renewal; with no renewal for `abandon_after_s` it gives the task up (`tick`
says `abandon`: the user may have revoked it in a message the robot missed). The reports
that end a task (completed, failed, abandoned, declined) are kept in `EndReports` and sent
again whenever the user still renews that grant, until it stops (the first was lost).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Generic, TypeVar

R = TypeVar("R")
ENDED_KEPT = 64


@dataclass
class Execution:
    """One granted task as its executor holds it."""

    started_at: float
    renewed_at: float
    abandon_after_s: float
    progress_period_s: float | None = None
    """None: progress goes out in answer to renewals only."""
    next_progress: float = 0.0
    fraction: float = 0.0
    note: str = ""

    @classmethod
    def start(cls, now: float, abandon_after_s: float,
              progress_period_s: float | None = None) -> Execution:
        nxt = now + progress_period_s if progress_period_s is not None else 0.0
        return cls(now, now, abandon_after_s, progress_period_s, nxt)

    def renewed(self, now: float) -> None:
        self.renewed_at = now

    def progress(self, fraction: float, note: str = "") -> None:
        self.fraction = min(1.0, max(0.0, float(fraction)))
        self.note = note

    @property
    def abandon_reason(self) -> str:
        return f"no renewal for {self.abandon_after_s:g} s"

    def tick(self, now: float) -> str | None:
        """`abandon` (no renewal for too long), `progress` (a report is due) or None."""
        if now - self.renewed_at > self.abandon_after_s:
            return "abandon"
        period = self.progress_period_s
        if period is not None and now >= self.next_progress:
            self.next_progress = now + period
            return "progress"
        return None


class EndReports(Generic[R]):
    """The end reports of the latest tasks (the oldest forgotten past `kept`)."""

    def __init__(self, kept: int = ENDED_KEPT) -> None:
        self._reports: OrderedDict[Hashable, R] = OrderedDict()
        self._kept = kept

    def remember(self, key: Hashable, report: R) -> None:
        self._reports[key] = report
        while len(self._reports) > self._kept:
            self._reports.popitem(last=False)

    def get(self, key: Hashable) -> R | None:
        return self._reports.get(key)

    def __contains__(self, key: object) -> bool:
        return key in self._reports
