"""The auctioneer: a sans-IO state machine that allocates tasks one round at a time.

Per task: BIDDING (announcement out, collecting bids until the window closes) -> CONTRACTED
(award out; renewals every period; the winner's progress keeps the contract alive) -> done, or
WAITING (before the next attempt) -> BIDDING again. No bid closes the round with an `Award`
without winner; the task is `unachievable` unless a `RetryPlan` schedules another round before
its deadline. A winner that is silent for `contract_timeout_s` is dropped: the auctioneer sends
`Revoke`, stops renewing, and waits `abandon_after_s` (the time after which a winner that hears
no renewals gives up) before re-announcing, so the old and the new winner never overlap. A
winner that declines or says it abandoned the task is replaced at once.

`handle(message, now)` and `tick(now)` return `Outgoing` messages; finished tasks' `Outcome`s
are collected with `take_outcomes()`; every step is reported to `observer(AuctionEvent)`.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from murdoch.auction.messages import (
    Announce,
    AuctionEvent,
    Award,
    Bid,
    Outcome,
    Outgoing,
    Progress,
    Renew,
    Report,
    Revoke,
    TaskSpec,
    negotiation_subject,
)
from murdoch.execution.user_side import (
    AT_ONCE_S,
    Lease,
    next_attempt,
    no_winner,
    on_report,
    outcome,
)
from murdoch.subjects import check_subject

log = logging.getLogger(__name__)

Observer = Callable[[AuctionEvent], None]


@dataclass(frozen=True)
class RetryPlan:
    """Reintroduce an unachievable task after `delay_s(tries)` until `deadline`."""

    deadline: float
    delay_s: Callable[[int], float]


class Phase(enum.Enum):
    BIDDING = "bidding"
    CONTRACTED = "contracted"
    WAITING = "waiting"


def best_bid(bids: dict[str, float]) -> tuple[str, float]:
    """Highest score; ties go to the lexicographically smallest bidder id."""
    bidder, score = min(bids.items(), key=lambda item: (-item[1], item[0]))
    return bidder, score


@dataclass
class _Task:
    task_id: str
    spec: TaskSpec
    negotiation: str
    retry: RetryPlan | None
    introduced_at: float
    attempt: int = 0
    phase: Phase = Phase.BIDDING
    close_at: float = 0.0
    bids: dict[str, float] = field(default_factory=dict)
    winner: str | None = None
    lease: Lease | None = None
    fraction: float = 0.0
    wake_at: float = 0.0
    no_bid_rounds: int = 0
    last_reason: str = ""


class Auctioneer:
    def __init__(
        self, agent_id: str, observer: Observer | None = None, task_prefix: str | None = None
    ) -> None:
        """`task_prefix` (default: the agent id) starts every task id this auctioneer makes;
        give each run of a process its own (`Node` adds the transport's instance nonce)."""
        self.agent_id = check_subject(agent_id)
        self.task_prefix = check_subject(task_prefix or agent_id)
        self._observer = observer
        self._tasks: dict[str, _Task] = {}
        self._outcomes: list[Outcome] = []
        self._counter = 0

    # -- queries
    def interest(self) -> frozenset[str]:
        """Negotiation subjects this auctioneer must hear."""
        return frozenset(t.negotiation for t in self._tasks.values())

    def open_tasks(self) -> tuple[str, ...]:
        return tuple(self._tasks)

    @property
    def has_open_tasks(self) -> bool:
        return bool(self._tasks)

    def phase_of(self, task_id: str) -> Phase | None:
        task = self._tasks.get(task_id)
        return task.phase if task else None

    def winner_of(self, task_id: str) -> str | None:
        task = self._tasks.get(task_id)
        return task.winner if task and task.phase is Phase.CONTRACTED else None

    def next_wakeup(self) -> float | None:
        """The earliest time at which `tick` has something to do."""
        times = []
        for t in self._tasks.values():
            if t.phase is Phase.BIDDING:
                times.append(t.close_at)
            elif t.phase is Phase.CONTRACTED and t.lease is not None:
                lease = t.lease
                times.append(min(lease.renew_at, lease.last_heard + t.spec.contract_timeout_s))
            else:
                times.append(t.wake_at)
        return min(times) if times else None

    def take_outcomes(self) -> list[Outcome]:
        outcomes, self._outcomes = self._outcomes, []
        return outcomes

    # -- inputs
    def announce(
        self,
        spec: TaskSpec,
        now: float,
        task_id: str | None = None,
        retry: RetryPlan | None = None,
    ) -> tuple[str, list[Outgoing]]:
        """Introduce a task; returns its id and the announcement to publish."""
        if task_id is None:
            self._counter += 1
            task_id = f"{self.task_prefix}.{self._counter}"
        if task_id in self._tasks:
            raise ValueError(f"task {task_id} is already open")
        task = _Task(task_id, spec, negotiation_subject(task_id), retry, now)
        self._tasks[task_id] = task
        return task_id, self._start_round(task, now)

    def cancel(self, task_id: str, now: float, reason: str = "cancelled") -> list[Outgoing]:
        task = self._tasks.get(task_id)
        if task is None:
            return []
        out = []
        if task.phase is Phase.CONTRACTED and task.winner is not None:
            out.append(self._send(task, Revoke(task_id, task.attempt, task.winner, reason)))
        self._finish(task, now, "failed", reason)
        return out

    def handle(self, message: Any, now: float) -> list[Outgoing]:
        task = self._tasks.get(getattr(message, "task_id", ""))
        if task is None:
            return []
        if isinstance(message, Bid):
            self._on_bid(task, message, now)
        elif isinstance(message, Progress):
            self._on_progress(task, message, now)
        elif isinstance(message, Report):
            return self._on_report(task, message, now)
        return []

    def tick(self, now: float) -> list[Outgoing]:
        out: list[Outgoing] = []
        for task in list(self._tasks.values()):
            if task.phase is Phase.BIDDING and now >= task.close_at:
                out.extend(self._close(task, now))
            elif task.phase is Phase.CONTRACTED:
                out.extend(self._monitor(task, now))
            elif task.phase is Phase.WAITING and now >= task.wake_at:
                out.extend(self._start_round(task, now))
        return out

    # -- steps
    def _start_round(self, task: _Task, now: float) -> list[Outgoing]:
        spec = task.spec
        gave_up = next_attempt(task.attempt, spec)
        if gave_up is not None:
            task.winner = None
            self._finish(task, now, "failed", gave_up)
            return []
        task.attempt += 1
        task.phase = Phase.BIDDING
        task.bids = {}
        task.winner = None
        task.close_at = now + spec.bid_window_s
        message = Announce(
            task_id=task.task_id,
            attempt=task.attempt,
            name=spec.name,
            subjects=tuple(sorted(spec.subjects)),
            params=spec.params,
            duration_s=spec.duration_s,
            metrics=spec.metrics,
            negotiation=task.negotiation,
            bid_window_s=spec.bid_window_s,
            renew_period_s=spec.renew_period_s,
            abandon_after_s=spec.abandon_after_s,
            parent=spec.parent,
        )
        self._emit(now, "announce", task, name=spec.name, subjects=sorted(spec.subjects))
        return [Outgoing(spec.announce_subjects, message)]

    def _on_bid(self, task: _Task, bid: Bid, now: float) -> None:
        if bid.attempt != task.attempt or task.phase is not Phase.BIDDING:
            return
        if now > task.close_at or bid.bidder in task.bids:
            return
        task.bids[bid.bidder] = bid.score
        if self._observer is not None:
            self._emit(now, "bid", task, bidder=bid.bidder, score=bid.score)

    def _close(self, task: _Task, now: float) -> list[Outgoing]:
        self._emit(now, "close", task, bids=len(task.bids))
        if not task.bids:
            task.no_bid_rounds += 1
            plan = task.retry
            verdict = no_winner(now, task.spec, task.attempt, task.no_bid_rounds,
                                task.last_reason, plan.deadline if plan else None,
                                plan.delay_s if plan else None)
            award = Award(task.task_id, task.attempt, None, None, 0, verdict.reason)
            out = [self._send(task, award)]
            if verdict.retry_in_s is not None:
                task.phase = Phase.WAITING
                task.wake_at = now + verdict.retry_in_s
                self._emit(now, "retry", task, delay_s=verdict.retry_in_s, reason=verdict.reason)
                return out
            self._finish(task, now, "unachievable", verdict.final_reason)
            return out
        winner, score = best_bid(task.bids)
        task.phase = Phase.CONTRACTED
        task.winner = winner
        task.lease = Lease.grant(winner, now, task.spec,
                                 task.lease.renewals if task.lease is not None else 0)
        task.fraction = 0.0
        self._emit(now, "award", task, winner=winner, score=score, bids=len(task.bids))
        award = Award(task.task_id, task.attempt, winner, score, len(task.bids), "")
        return [self._send(task, award)]

    def _monitor(self, task: _Task, now: float) -> list[Outgoing]:
        assert task.winner is not None and task.lease is not None
        step = task.lease.check(task.spec, now)
        if step is None:
            return []
        if step.kind == "renew":
            self._emit(now, "renew", task, winner=task.winner, n=step.n)
            return [self._send(task, Renew(task.task_id, task.attempt, task.winner, step.n))]
        out = [self._send(task, Revoke(task.task_id, task.attempt, task.winner, step.reason))]
        if step.kind == "expired":
            self._finish(task, now, "failed", step.reason)
        else:
            self._reallocate(task, now, step.reason, wait_s=step.wait_s)
        return out

    def _on_progress(self, task: _Task, progress: Progress, now: float) -> None:
        if (
            task.phase is Phase.CONTRACTED
            and progress.attempt == task.attempt
            and progress.winner == task.winner
            and task.lease is not None
        ):
            task.lease.last_heard = now
            task.fraction = progress.fraction
            self._emit(now, "progress", task, winner=task.winner, fraction=progress.fraction)

    def _on_report(self, task: _Task, report: Report, now: float) -> list[Outgoing]:
        if report.attempt != task.attempt or report.winner != task.winner:
            return []
        if task.phase is Phase.BIDDING:
            return []
        meaning = on_report(report.status)
        if meaning == "end":
            self._finish(task, now, report.status, report.reason or report.status)
        elif meaning == "reoffer" and task.phase is Phase.CONTRACTED:
            reason = f"winner {report.winner} {report.status}: {report.reason}"
            self._reallocate(task, now, reason, wait_s=AT_ONCE_S)
        return []

    def _reallocate(self, task: _Task, now: float, reason: str, wait_s: float) -> None:
        self._emit(now, "reallocation", task, winner=task.winner, reason=reason)
        task.last_reason = reason
        task.phase = Phase.WAITING
        task.wake_at = now + wait_s

    def _finish(self, task: _Task, now: float, status: str, reason: str) -> None:
        del self._tasks[task.task_id]
        ended = outcome(task.task_id, task.spec, status, reason, task.winner, task.attempt, now)
        self._outcomes.append(ended)
        self._emit(now, "outcome", task, status=status, reason=reason, winner=ended.winner)

    def _send(self, task: _Task, message: Any) -> Outgoing:
        return Outgoing(frozenset({task.negotiation}), message)

    def _emit(self, now: float, kind: str, task: _Task, **detail: Any) -> None:
        if self._observer is not None:
            event = AuctionEvent(now, self.agent_id, kind, task.task_id, task.attempt, detail)
            self._observer(event)
