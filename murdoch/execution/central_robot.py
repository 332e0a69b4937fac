"""A robot's member of a centrally allocated team: status out, orders in, the contract kept.

The same for every central allocator: the allocator's code runs on the user's side only
(`central_user`). The robot says what it is (`RobotStatus`: its subjects, none while
charging; its pose, battery and the task it runs) when that changes and every
`HEARTBEAT_S` (its liveness); it starts the task a `TaskOrder` naming it gives (refusing,
with an `abandoned` report, one it cannot do or that comes while it is busy or away), and
then keeps the team-member contract (`murdoch.execution.executor`): the repeated order is a
renewal, progress goes out every renewal period, no renewal for the abandon time gives the
task up, a `TaskWithdraw` stops it, and an end report is sent again while the order is still
repeated.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable

from murdoch.allocators.base import Assignment, RobotHooks
from murdoch.allocators.team_messages import STATE_SUBJECT, TEAM_SUBJECT, TaskReport, TaskWithdraw
from murdoch.auction.messages import AuctionEvent, TaskSpec
from murdoch.auction.timing import USER_TASK
from murdoch.execution.executor import EndReports, Execution
from murdoch.execution.messages import RobotStatus, TaskOrder
from murdoch.subjects import SubjectSet, subject_set
from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)

HEARTBEAT_S = 5.0
PROGRESS_S = USER_TASK.renew_period_s
ABANDON_AFTER_S = USER_TASK.abandon_after_s


class CentralRobot:
    """A robot's `TeamMember` under any central allocator."""

    def __init__(self, transport: Transport, clock: Clock, hooks: RobotHooks) -> None:
        self.transport = transport
        self.clock = clock
        self.hooks = hooks
        self._subjects: SubjectSet = subject_set(hooks.subjects)
        self._lock = threading.RLock()
        self._executing: TaskOrder | None = None
        self._execution = Execution.start(0.0, ABANDON_AFTER_S, PROGRESS_S)
        self._ended: EndReports[TaskReport] = EndReports()
        self._status_key: tuple[object, ...] | None = None
        self._status_at = 0.0
        self.counters = {"orders": 0, "refused": 0}
        self._sub = transport.subscribe({TEAM_SUBJECT})
        self.closed = False

    # -- capabilities
    @property
    def subjects(self) -> SubjectSet:
        return self._subjects

    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        with self._lock:
            self._subjects = subject_set(subjects)

    # -- under a central allocator only the user introduces tasks
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str:
        raise ValueError(f"a central allocator's robot cannot introduce sub-tasks ({spec.name}); "
                         f"use the murdoch allocator for experiments that need them")

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        raise ValueError("a central allocator's robot introduces no tasks to cancel")

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

    # -- the loop
    def step(self, timeout_s: float = 0.0) -> int:
        with self._lock:
            if self.closed:
                return 0
            self.transport.poll(timeout_s)
            envelopes = self._sub.drain()
            now = self.clock()
            for envelope in envelopes:
                self._handle(envelope.message, now)
            self._keep(now)
            self._status(now)
            return len(envelopes)

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self.closed = True
                self._sub.close()

    # -- internals
    def _end(self, task_id: str, status: str, reason: str) -> None:
        with self._lock:
            ex = self._executing
            if ex is None or ex.task_id != task_id:
                return
            self._executing = None
            self._report(ex, status, reason)

    def _report(self, order: TaskOrder, status: str, reason: str) -> None:
        report = TaskReport(order.task_id, order.offer, self.hooks.agent_id, status,
                            self._execution.fraction, reason)
        if status != "progress":
            self._ended.remember(order.offer, report)
        self._publish(STATE_SUBJECT, report)

    def _handle(self, msg: object, now: float) -> None:
        me = self.hooks.agent_id
        ex = self._executing
        if isinstance(msg, TaskOrder) and msg.robot == me:
            ended = self._ended.get(msg.offer)
            if ex is not None and ex.offer == msg.offer:
                self._execution.renewed(now)
            elif ended is not None:
                self._publish(STATE_SUBJECT, ended)  # the end report was lost
            else:
                self._start(msg, now)
        elif isinstance(msg, TaskWithdraw) and ex is not None and ex.offer == msg.offer:
            self._stop(ex, now, msg.reason)

    def _start(self, order: TaskOrder, now: float) -> None:
        why = ""
        if self._executing is not None:
            why = f"busy with {self._executing.task_id}"
        elif not self._subjects:
            why = "left the team (charging)"
        elif not self.hooks.knows(order.name):
            why = f"cannot do {order.name}"
        if why:
            self.counters["refused"] += 1
            self._ended.remember(order.offer, TaskReport(order.task_id, order.offer,
                                                         self.hooks.agent_id, "abandoned", 0.0,
                                                         why))
            self._publish(STATE_SUBJECT, self._ended.get(order.offer))
            return
        self._executing = order
        self._execution = Execution.start(now, ABANDON_AFTER_S, PROGRESS_S)
        self.counters["orders"] += 1
        self._emit(now, "start", order.task_id, offer=order.offer)
        self.hooks.on_start(Assignment(order.task_id, order.name, order.params))

    def _stop(self, order: TaskOrder, now: float, reason: str) -> None:
        self._executing = None
        self._emit(now, "stopped", order.task_id, reason=reason)
        self.hooks.on_stop(Assignment(order.task_id, order.name, order.params), reason)

    def _keep(self, now: float) -> None:
        ex = self._executing
        due = self._execution.tick(now) if ex is not None else None
        if ex is None or due is None:
            return
        if due == "abandon":
            reason = self._execution.abandon_reason
            self._stop(ex, now, reason)
            self._report(ex, "abandoned", reason)
        else:
            self._report(ex, "progress", "")

    def _status(self, now: float) -> None:
        h = self.hooks
        key = (tuple(sorted(self._subjects)), self.executing or "")
        if key == self._status_key and now - self._status_at < HEARTBEAT_S:
            return
        self._status_key, self._status_at = key, now
        x, y, yaw = h.pose() if h.pose is not None else (*h.position(), 0.0)
        battery = h.battery() if h.battery is not None else None
        self._publish(STATE_SUBJECT, RobotStatus(
            h.agent_id, key[0], float(x), float(y), float(yaw), key[1],
            -1.0 if battery is None else float(battery), float(h.speed_mps)))

    def _publish(self, subject: str, message: object) -> None:
        try:
            self.transport.publish({subject}, message)
        except OSError as exc:  # silence is handled like loss
            log.warning("could not send %s: %s", type(message).__name__, exc)

    def _emit(self, now: float, kind: str, task_id: str, **detail: object) -> None:
        if self.hooks.observer is not None:
            self.hooks.observer(AuctionEvent(now, self.hooks.agent_id, kind, task_id, 0,
                                             dict(detail)))
