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

from murdoch.allocators.base import Assignment, RobotHooks
from murdoch.allocators.team_messages import STATE_SUBJECT, TEAM_SUBJECT, TaskReport, TaskWithdraw
from murdoch.execution.executor import Execution
from murdoch.execution.messages import RobotStatus, TaskOrder
from murdoch.execution.task_robot import ABANDON_AFTER_S, PROGRESS_S, TaskRobot
from murdoch.transport import Clock, Transport

HEARTBEAT_S = 5.0


class CentralRobot(TaskRobot[TaskOrder]):
    """A robot's `TeamMember` under any central allocator."""

    def __init__(self, transport: Transport, clock: Clock, hooks: RobotHooks) -> None:
        self._status_key: tuple[object, ...] | None = None
        self._status_at = 0.0
        self.counters = {"orders": 0, "refused": 0}
        super().__init__(transport, clock, hooks, {TEAM_SUBJECT})

    @property
    def _who(self) -> str:
        return "a central allocator's robot"

    def _advance(self, now: float) -> None:
        self._keep(now)
        self._status(now)

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
