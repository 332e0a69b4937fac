"""A robot's member of a team: it executes the tasks it is granted and introduces none.

What the robot's side of every allocator that grants over the bus shares (`central_robot`,
`murdoch.allocators.consensus_robot`): its capabilities (`set_subjects`), the refusal of
sub-tasks, the executor's calls (`progress`, `complete`, `fail`, `abandon`) and its half of
the contract (`murdoch.execution.executor`): progress every renewal period, the task given
up (and said so) when no renewal came for the abandon time, a task stopped when withdrawn,
and the end reports kept to be sent again. How a task is granted is the subclass's.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Generic, TypeVar

from murdoch.allocators.base import Assignment, RobotHooks
from murdoch.allocators.team_messages import STATE_SUBJECT, TaskOffer, TaskReport
from murdoch.auction.messages import AuctionEvent, TaskSpec
from murdoch.auction.timing import USER_TASK
from murdoch.execution.bus_member import BusMember
from murdoch.execution.executor import ENDED_KEPT, EndReports, Execution
from murdoch.execution.messages import TaskOrder
from murdoch.subjects import SubjectSet, subject_set
from murdoch.transport import Clock, Transport

PROGRESS_S = USER_TASK.renew_period_s
ABANDON_AFTER_S = USER_TASK.abandon_after_s


H = TypeVar("H", TaskOrder, TaskOffer)
"""What a robot holds of the task it executes: the order, or the offer it was granted."""


class TaskRobot(BusMember, Generic[H]):
    """A `TeamMember` that executes what it is granted, one task at a time."""

    def __init__(self, transport: Transport, clock: Clock, hooks: RobotHooks,
                 listen: Iterable[str], ended_kept: int = ENDED_KEPT) -> None:
        self.hooks = hooks
        self._subjects: SubjectSet = subject_set(hooks.subjects)
        self._executing: H | None = None
        self._execution = Execution.start(0.0, ABANDON_AFTER_S, PROGRESS_S)
        self._ended: EndReports[TaskReport] = EndReports(ended_kept)
        """The end reports of the latest tasks, sent again while the user still renews."""
        super().__init__(transport, clock, listen)

    @property
    def _who(self) -> str:
        """The robot, as its refusal to introduce tasks names it."""
        raise NotImplementedError

    def _subjects_changed(self) -> None:
        """Called when the robot's capabilities change."""

    def _freed(self) -> None:
        """Called when the robot stops executing a task."""

    # -- capabilities
    @property
    def subjects(self) -> SubjectSet:
        return self._subjects

    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        with self._lock:
            new = subject_set(subjects)
            if new != self._subjects:
                self._subjects = new
                self._subjects_changed()

    # -- tasks: only the user introduces them
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str:
        raise ValueError(f"{self._who} cannot introduce sub-tasks ({spec.name}); "
                         f"use the murdoch allocator for experiments that need them")

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        raise ValueError(f"{self._who} introduces no tasks to cancel")

    def open_tasks(self) -> tuple[str, ...]:
        return ()

    # -- execution
    @property
    def executing(self) -> str | None:
        ex = self._executing
        return ex.task_id if ex is not None else None

    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        with self._lock:
            if self.executing == task_id:
                self._execution.progress(fraction, note)

    def complete(self, task_id: str, note: str = "") -> None:
        self._end(task_id, "completed", note)

    def fail(self, task_id: str, reason: str) -> None:
        self._end(task_id, "failed", reason)

    def abandon(self, task_id: str, reason: str) -> None:
        self._end(task_id, "abandoned", reason)

    def _end(self, task_id: str, status: str, reason: str) -> None:
        with self._lock:
            ex = self._executing
            if ex is None or ex.task_id != task_id:
                return
            self._executing = None
            self._freed()
            self._report(ex, status, reason)

    def _report(self, held: H, status: str, reason: str) -> None:
        report = TaskReport(held.task_id, held.offer, self.hooks.agent_id, status,
                            self._execution.fraction, reason)
        if status != "progress":
            self._ended.remember(held.offer, report)
        self._publish(STATE_SUBJECT, report)

    def _stop(self, held: H, now: float, reason: str) -> None:
        self._executing = None
        self._freed()
        self._emit(now, "stopped", held.task_id, reason=reason)
        self.hooks.on_stop(Assignment(held.task_id, held.name, held.params), reason)

    def _keep(self, now: float) -> None:
        """The executor's timers: progress due, or the task given up (no renewal came)."""
        ex = self._executing
        due = self._execution.tick(now) if ex is not None else None
        if ex is None or due is None:
            return
        if due == "abandon":
            # the user has not renewed the grant: it may have given the task to another
            reason = self._execution.abandon_reason
            self._stop(ex, now, reason)
            self._report(ex, "abandoned", reason)
        else:
            self._report(ex, "progress", "")

    def _emit(self, now: float, kind: str, task_id: str, **detail: object) -> None:
        if self.hooks.observer is not None:
            self.hooks.observer(AuctionEvent(now, self.hooks.agent_id, kind, task_id, 0,
                                             dict(detail)))
