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
import threading
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from murdoch.allocators.base import UserHooks
from murdoch.allocators.team_messages import STATE_SUBJECT, TEAM_SUBJECT, TaskReport, TaskWithdraw
from murdoch.auction.messages import AuctionEvent, Outcome, TaskSpec
from murdoch.execution.messages import RobotStatus, TaskOrder
from murdoch.execution.user_side import (
    AT_ONCE_S,
    Lease,
    next_attempt,
    no_winner,
    on_report,
    outcome,
)
from murdoch.execution.views import RobotView, TaskView, WorldView
from murdoch.subjects import SubjectSet
from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)

SILENT_S = 15.0
"""A robot not heard for three heartbeats (`central_robot.HEARTBEAT_S`) is taken for gone."""

Decide = Callable[[WorldView], Mapping[str, str]]
"""The decision hook: the open tasks' executors (task id -> robot name), from the world."""


@dataclass
class _Task:
    task_id: str
    spec: TaskSpec
    deadline: float | None
    place: tuple[float, float] | None
    arrived_s: float
    attempt: int = 0
    phase: str = "waiting"  # open, granted, waiting
    offer: int = -1
    opened_at: float = 0.0
    wake_at: float = 0.0
    winner: str | None = None
    lease: Lease | None = None
    no_bid_rounds: int = 0
    last_reason: str = ""


class CentralUser:
    """The runner's `TeamMember` for a central allocator (`decide`)."""

    def __init__(self, transport: Transport, clock: Clock, hooks: UserHooks,
                 decide: Decide) -> None:
        self.transport = transport
        self.clock = clock
        self.hooks = hooks
        self.decide = decide
        inst = transport.instance
        self._prefix = f"{hooks.agent_id}.{inst[:6]}" if inst else hooks.agent_id
        self._counter = 0
        self._offers = 0
        self._tasks: dict[str, _Task] = {}
        self._by_offer: dict[int, _Task] = {}
        self._robots: dict[str, tuple[float, RobotStatus]] = {}
        self._changed = False
        self._lock = threading.RLock()
        self.outcomes: deque[Outcome] = deque(maxlen=1024)
        self.counters = {"decisions": 0, "refused": 0}
        self._sub = transport.subscribe({STATE_SUBJECT})
        self.closed = False

    # -- the user executes nothing and offers no capabilities
    @property
    def subjects(self) -> SubjectSet:
        return frozenset()

    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        if subjects:
            raise ValueError("the user of a centrally allocated team executes no tasks")

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
            task = _Task(task_id, spec, None if patience_s is None else now + patience_s,
                         self.hooks.locate(spec.name, spec.params), now)
            self._tasks[task_id] = task
            self._open(task, now)
            return task_id

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        with self._lock:
            task = self._tasks.get(task_id)
            if task is not None:
                self._finish(task, self.clock(), "failed", reason)

    def open_tasks(self) -> tuple[str, ...]:
        return tuple(self._tasks)

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
            for name, (heard, _) in list(self._robots.items()):
                if now - heard > SILENT_S:
                    del self._robots[name]
                    self._changed = True
            for task in list(self._tasks.values()):
                self._tick(task, now)
            if self._changed:
                self._changed = False
                self._assign(now)
            return len(envelopes)

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self.closed = True
                self._sub.close()

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
            if task is None or task.phase != "granted" or task.winner != msg.robot:
                return
            assert task.lease is not None
            task.lease.last_heard = now
            meaning = on_report(msg.status)
            if meaning == "end":
                self._finish(task, now, msg.status, msg.reason or msg.status)
            elif meaning == "reoffer":
                self._reallocate(task, now, f"winner {msg.robot} {msg.status}: {msg.reason}",
                                 AT_ONCE_S)

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
            if step is None:
                return
            if step.kind == "expired":
                self._finish(task, now, "failed", step.reason)
            elif step.kind == "silent":
                self._reallocate(task, now, step.reason, step.wait_s)
            else:
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
        gave_up = next_attempt(task.attempt, task.spec)
        if gave_up is not None:
            task.winner = None
            task.phase = "waiting"
            self._finish(task, now, "failed", gave_up)
            return
        task.attempt += 1
        task.phase = "open"
        task.winner = None
        task.opened_at = now
        task.offer = self._offers
        self._offers += 1
        self._by_offer[task.offer] = task
        self._changed = True
        self._emit(now, "announce", task, name=task.spec.name,
                   subjects=sorted(task.spec.subjects), offer=task.offer)

    def _grant(self, task: _Task, robot: RobotView, cost: float, candidates: int,
               now: float) -> None:
        task.phase = "granted"
        task.winner = robot.name
        task.lease = Lease.grant(robot.name, now, task.spec)
        self._emit(now, "close", task, bids=candidates)
        self._emit(now, "award", task, winner=robot.name, score=-cost, bids=candidates)
        self._send_order(task)

    def _send_order(self, task: _Task) -> None:
        assert task.winner is not None
        self._publish(TEAM_SUBJECT, TaskOrder(task.task_id, task.offer, task.winner,
                                              task.spec.name, task.spec.params))

    def _withdraw(self, task: _Task, reason: str) -> None:
        if self._by_offer.pop(task.offer, None) is not None and task.phase == "granted":
            self._publish(TEAM_SUBJECT, TaskWithdraw(task.task_id, task.offer, reason))

    def _no_winner(self, task: _Task, now: float) -> None:
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

    def _reallocate(self, task: _Task, now: float, reason: str, wait_s: float) -> None:
        self._emit(now, "reallocation", task, winner=task.winner, reason=reason)
        self._withdraw(task, reason)
        task.last_reason = reason
        task.phase = "waiting"
        task.wake_at = now + wait_s
        self._changed = True

    def _finish(self, task: _Task, now: float, status: str, reason: str) -> None:
        self._tasks.pop(task.task_id, None)
        self._withdraw(task, reason)
        self._changed = True
        ended = outcome(task.task_id, task.spec, status, reason, task.winner, task.attempt, now)
        self.outcomes.append(ended)
        self._emit(now, "outcome", task, status=status, reason=reason, winner=ended.winner)

    def _publish(self, subject: str, message: object) -> None:
        try:
            self.transport.publish({subject}, message)
        except OSError as exc:
            log.warning("could not send %s: %s", type(message).__name__, exc)

    def _emit(self, now: float, kind: str, task: _Task, **detail: object) -> None:
        if self.hooks.observer is not None:
            self.hooks.observer(AuctionEvent(now, self.hooks.agent_id, kind, task.task_id,
                                             task.attempt, dict(detail)))
