"""The user's member of a team: it introduces tasks and executes none.

What the user's side of every allocator that grants over the bus shares (`central_user`,
`murdoch.allocators.consensus_user`): it offers no capabilities and takes no executor's
calls, numbers the tasks it introduces (`announce`), cancels and lists them, ticks each at
every step, and ends each exactly once (`_finish`: the grant withdrawn, one `Outcome`, one
`outcome` event). The steps of the contract that do not depend on how a task is offered
live here too: the next attempt or the end (`_next_attempt`), the grant (`_granted`), the
executor's reports (`_reported`), the lease's verdicts (`_lease_ended`), an attempt without
executor (`_no_winner`) and a reallocation (`_reallocate`). How a task is offered and granted
is the subclass's (`_new_task`, `_introduce`, `_tick`, `_release`, `_withdraw`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Generic, TypeVar

from murdoch.allocators.base import UserHooks
from murdoch.allocators.team_messages import TaskReport
from murdoch.auction.messages import AuctionEvent, Outcome, TaskSpec
from murdoch.execution.bus_member import BusMember
from murdoch.execution.user_side import (
    AT_ONCE_S,
    Lease,
    LeaseStep,
    next_attempt,
    no_winner,
    on_report,
    outcome,
)
from murdoch.subjects import SubjectSet
from murdoch.transport import Clock, Transport


@dataclass
class UserTask:
    """What the user keeps of a task it introduced, as far as the shared steps go (each
    allocator's user adds its own fields, keyword-only)."""

    task_id: str
    spec: TaskSpec
    deadline: float | None
    attempt: int = 0
    phase: str = "waiting"
    wake_at: float = 0.0
    winner: str | None = None
    lease: Lease | None = None
    no_bid_rounds: int = 0
    last_reason: str = ""


T = TypeVar("T", bound=UserTask)


class TaskUser(BusMember, Generic[T]):
    """A `TeamMember` that introduces tasks and executes none."""

    TEAM = "team"
    """What the user belongs to, as the refusal of capabilities names it."""

    def __init__(self, transport: Transport, clock: Clock, hooks: UserHooks,
                 listen: Iterable[str]) -> None:
        self.hooks = hooks
        inst = transport.instance
        self._prefix = f"{hooks.agent_id}.{inst[:6]}" if inst else hooks.agent_id
        self._counter = 0
        self._offers = 0
        self._tasks: dict[str, T] = {}
        self._by_offer: dict[int, T] = {}
        self.outcomes: deque[Outcome] = deque(maxlen=1024)
        """The latest outcomes of the tasks this member introduced."""
        super().__init__(transport, clock, listen)

    # -- the user executes nothing and offers no capabilities
    @property
    def subjects(self) -> SubjectSet:
        return frozenset()

    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        if subjects:
            raise ValueError(f"the user of {self.TEAM} executes no tasks")

    @property
    def executing(self) -> str | None:
        return None

    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        pass

    def complete(self, task_id: str, note: str = "") -> None:
        pass

    def fail(self, task_id: str, reason: str) -> None:
        pass

    def abandon(self, task_id: str, reason: str) -> None:
        pass

    # -- tasks
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str:
        with self._lock:
            now = self.clock()
            self._counter += 1
            task_id = f"{self._prefix}.{self._counter}"
            deadline = None if patience_s is None else now + patience_s
            task = self._new_task(task_id, spec, deadline,
                                  self.hooks.locate(spec.name, spec.params), now)
            self._tasks[task_id] = task
            self._introduce(task, now)
            return task_id

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        with self._lock:
            task = self._tasks.get(task_id)
            if task is not None:
                self._finish(task, self.clock(), "failed", reason)

    def open_tasks(self) -> tuple[str, ...]:
        return tuple(self._tasks)

    # -- what a subclass says
    def _new_task(self, task_id: str, spec: TaskSpec, deadline: float | None,
                  place: tuple[float, float], now: float) -> T:
        raise NotImplementedError

    def _introduce(self, task: T, now: float) -> None:
        """Offer a task's first attempt."""
        raise NotImplementedError

    def _tick(self, task: T, now: float) -> None:
        raise NotImplementedError

    def _withdraw(self, task: T, reason: str) -> None:
        """Take back a task's current offer or grant."""
        raise NotImplementedError

    def _release(self, task: T, reason: str) -> None:
        """Take back whatever a task that ends still holds out on the bus."""
        raise NotImplementedError

    # -- shared steps
    def _advance(self, now: float) -> None:
        for task in list(self._tasks.values()):
            self._tick(task, now)

    def _next_attempt(self, task: T, now: float) -> bool:
        """Start a task's next attempt (True), or end it when it has had them all."""
        gave_up = next_attempt(task.attempt, task.spec)
        if gave_up is not None:
            task.winner = None
            task.phase = "waiting"
            self._finish(task, now, "failed", gave_up)
            return False
        task.attempt += 1
        task.winner = None
        return True

    def _granted(self, task: T, robot: str, now: float, bids: int, score: float) -> None:
        """Grant a task to one robot: the lease starts, the close and the award are told."""
        task.phase = "granted"
        task.winner = robot
        task.lease = Lease.grant(robot, now, task.spec)
        self._emit(now, "close", task, bids=bids)
        self._emit(now, "award", task, winner=robot, score=score, bids=bids)

    def _reported(self, task: T, msg: TaskReport, now: float) -> None:
        """The executor of a granted task reported: the lease lives on, or the task ends or
        is offered again."""
        assert task.lease is not None
        task.lease.last_heard = now
        meaning = on_report(msg.status)
        if meaning == "end":
            self._finish(task, now, msg.status, msg.reason or msg.status)
        elif meaning == "reoffer":
            self._reallocate(task, now, f"winner {msg.robot} {msg.status}: {msg.reason}",
                             AT_ONCE_S)

    def _lease_ended(self, task: T, step: LeaseStep, now: float) -> bool:
        """Act on a lease's step; whether it ended the grant (else: renew it)."""
        if step.kind == "expired":
            self._finish(task, now, "failed", step.reason)
        elif step.kind == "silent":
            self._reallocate(task, now, step.reason, step.wait_s)
        return step.kind != "renew"

    def _no_winner(self, task: T, now: float) -> None:
        """An attempt found no executor: retry after the backoff, or unachievable."""
        self._emit(now, "close", task, bids=0)
        self._withdraw(task, "no winner")
        task.no_bid_rounds += 1
        verdict = no_winner(now, task.spec, task.attempt, task.no_bid_rounds, task.last_reason,
                            task.deadline, self.hooks.backoff.delay_s)
        if verdict.retry_in_s is not None:
            task.phase = "waiting"
            task.wake_at = now + verdict.retry_in_s
            self._emit(now, "retry", task, delay_s=verdict.retry_in_s, reason=verdict.reason)
            return
        task.winner = None
        self._finish(task, now, "unachievable", verdict.final_reason)

    def _reallocate(self, task: T, now: float, reason: str, wait_s: float) -> None:
        self._emit(now, "reallocation", task, winner=task.winner, reason=reason)
        self._withdraw(task, reason)
        task.last_reason = reason
        task.phase = "waiting"
        task.wake_at = now + wait_s

    def _finish(self, task: T, now: float, status: str, reason: str) -> None:
        self._tasks.pop(task.task_id, None)
        self._release(task, reason)
        ended = outcome(task.task_id, task.spec, status, reason, task.winner, task.attempt, now)
        self.outcomes.append(ended)
        self._emit(now, "outcome", task, status=status, reason=reason, winner=ended.winner)

    def _emit(self, now: float, kind: str, task: T, **detail: object) -> None:
        if self.hooks.observer is not None:
            self.hooks.observer(AuctionEvent(now, self.hooks.agent_id, kind, task.task_id,
                                             task.attempt, dict(detail)))
