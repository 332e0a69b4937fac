"""The user's member of a centrally allocated team: one decision hook, the contract here.

The runner introduces tasks as under every allocator (`announce`, with patience). This
member holds them, hears the robots' `RobotStatus` (what each offers, where it is, whether it
is busy, its battery), and whenever something changes that could change a decision (a task
opens, a robot frees up, is found silent, leaves to charge or comes back) hands the decision
hook (`Decide`, a `murdoch.plugin.CentralAllocator`'s `assign`) a `WorldView` of the open
tasks and the robots, and grants each task it assigns (`TaskOrder`). An open task that is
not assigned stays open (queued) while some robot of the team offers what it needs, free or
busy, and the task's patience lasts; the hook is asked again at each change. From there the
team-member contract (`murdoch.execution`) runs as under the other allocators: the grant
is renewed every renewal period, the executor's reports keep it alive and end it, a silent
executor is revoked (`TaskWithdraw`) and the task offered again once it has given up; a
task that no robot of the team can do for a whole bid window (or still unassigned when its
patience runs out) is an attempt without executor: retried after the backoff while its
patience lasts, then `unachievable`. Events read as the auctioneer's (announce,
close, award, reallocation, retry, outcome).

An assignment the hook returns that names an unknown or taken task, a robot that is not
free or not capable, or one robot twice, is dropped, counted (`counters["refused"]`) and
logged; `murdoch.plugin.check_allocator` names such a hook before any run.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from murdoch.allocators.base import UserHooks
from murdoch.allocators.team_messages import STATE_SUBJECT, TEAM_SUBJECT, TaskReport, TaskWithdraw
from murdoch.auction.messages import TaskSpec
from murdoch.execution.messages import RobotStatus, TaskOrder
from murdoch.execution.task_user import TaskUser, UserTask
from murdoch.execution.views import RobotView, TaskView, WorldView
from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)

SILENT_S = 15.0
"""A robot not heard for three heartbeats (`central_robot.HEARTBEAT_S`) is taken for gone."""

Decide = Callable[[WorldView], Mapping[str, str]]
"""The decision hook: the open tasks' executors (task id -> robot name), from the world."""


@dataclass(kw_only=True)
class _Task(UserTask):
    """A task as this user keeps it (phases: open, granted, waiting)."""

    place: tuple[float, float] | None
    arrived_s: float
    offer: int = -1
    opened_at: float = 0.0


class CentralUser(TaskUser[_Task]):
    """The runner's `TeamMember` for a central allocator (`decide`)."""

    TEAM = "a centrally allocated team"

    def __init__(self, transport: Transport, clock: Clock, hooks: UserHooks,
                 decide: Decide) -> None:
        self.decide = decide
        self._robots: dict[str, tuple[float, RobotStatus]] = {}
        self._changed = False
        self.counters = {"decisions": 0, "refused": 0}
        super().__init__(transport, clock, hooks, {STATE_SUBJECT})

    def _new_task(self, task_id: str, spec: TaskSpec, deadline: float | None,
                  place: tuple[float, float], now: float) -> _Task:
        return _Task(task_id, spec, deadline, place=place, arrived_s=now)

    def _introduce(self, task: _Task, now: float) -> None:
        self._open(task, now)

    def _advance(self, now: float) -> None:
        for name, (heard, _) in list(self._robots.items()):
            if now - heard > SILENT_S:
                del self._robots[name]
                self._changed = True
        super()._advance(now)
        if self._changed:
            self._changed = False
            self._assign(now)

    def world(self, now: float) -> WorldView:
        """What the decision hook is shown now."""
        holders = {t.winner: t.task_id for t in self._tasks.values()
                   if t.phase == "granted" and t.winner is not None}
        robots = tuple(
            RobotView(s.robot, (s.x, s.y, s.yaw), frozenset(s.subjects),
                      s.battery if s.battery >= 0 else None,
                      holders.get(s.robot) or s.busy or None, s.speed_mps)
            for _, s in (self._robots[n] for n in sorted(self._robots)))
        tasks = tuple(TaskView(t.task_id, t.spec.name, t.place, frozenset(t.spec.subjects),
                               t.arrived_s, t.spec.params, t.spec.duration_s, t.attempt)
                      for t in self._tasks.values() if t.phase == "open")
        return WorldView(now, tasks, robots)

    # -- internals
    def _handle(self, msg: object, now: float) -> None:
        if isinstance(msg, RobotStatus):
            old = self._robots.get(msg.robot)
            if old is None or (old[1].subjects, old[1].busy) != (msg.subjects, msg.busy):
                self._changed = True
            self._robots[msg.robot] = (now, msg)
        elif isinstance(msg, TaskReport):
            task = self._by_offer.get(msg.offer)
            if task is not None and task.phase == "granted" and task.winner == msg.robot:
                self._reported(task, msg, now)

    def _tick(self, task: _Task, now: float) -> None:
        if task.phase == "waiting":
            if now >= task.wake_at:
                self._open(task, now)
        elif task.phase == "open":
            if now - task.opened_at >= task.spec.bid_window_s and not self._queued(task, now):
                self._no_winner(task, now)
        elif task.phase == "granted":
            assert task.lease is not None
            step = task.lease.check(task.spec, now)
            if step is not None and not self._lease_ended(task, step, now):
                self._send_order(task)

    def _queued(self, task: _Task, now: float) -> bool:
        """Whether an open task waits in the queue: some robot in the team offers what it
        needs (free or busy) and its patience lasts. Otherwise it is an attempt without
        executor (backoff, then unachievable)."""
        if task.deadline is not None and now >= task.deadline:
            return False
        needs = task.spec.subjects
        return any(needs <= frozenset(s.subjects) for _, s in self._robots.values())

    def _assign(self, now: float) -> None:
        world = self.world(now)
        if not world.tasks or not any(r.free for r in world.robots):
            return
        self.counters["decisions"] += 1
        chosen = self.decide(world)
        open_ids = {t.id: t for t in world.tasks}
        robots = {r.name: r for r in world.robots}
        taken: set[str] = set()
        for task_id, robot in chosen.items():
            view, r = open_ids.get(task_id), robots.get(robot)
            if view is None or r is None or not r.free or robot in taken \
                    or not world.capable(r, view):
                self.counters["refused"] += 1
                log.warning("central allocator: refused %s -> %s (not an open task, or not "
                            "a free capable robot, or a robot twice)", task_id, robot)
                continue
            taken.add(robot)
            self._grant(self._tasks[task_id], r, world.cost(r, view), len(world.candidates(view)),
                        now)

    def _open(self, task: _Task, now: float) -> None:
        if not self._next_attempt(task, now):
            return
        task.phase = "open"
        task.opened_at = now
        task.offer = self._offers
        self._offers += 1
        self._by_offer[task.offer] = task
        self._changed = True
        self._emit(now, "announce", task, name=task.spec.name,
                   subjects=sorted(task.spec.subjects), offer=task.offer)

    def _grant(self, task: _Task, robot: RobotView, cost: float, candidates: int,
               now: float) -> None:
        self._granted(task, robot.name, now, candidates, -cost)
        self._send_order(task)

    def _send_order(self, task: _Task) -> None:
        assert task.winner is not None
        self._publish(TEAM_SUBJECT, TaskOrder(task.task_id, task.offer, task.winner,
                                              task.spec.name, task.spec.params))

    def _withdraw(self, task: _Task, reason: str) -> None:
        if self._by_offer.pop(task.offer, None) is not None and task.phase == "granted":
            self._publish(TEAM_SUBJECT, TaskWithdraw(task.task_id, task.offer, reason))

    def _reallocate(self, task: _Task, now: float, reason: str, wait_s: float) -> None:
        super()._reallocate(task, now, reason, wait_s)
        self._changed = True

    def _release(self, task: _Task, reason: str) -> None:
        self._withdraw(task, reason)
        self._changed = True
