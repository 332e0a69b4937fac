"""Glue between one robot's `RobotAgent` and its allocator (``murdoch-robot --mcast-port``).

The allocator is a `murdoch.member.TeamMember` taken by name from the registry
(`murdoch.allocators`, ``murdoch-robot --allocator murdoch|cbba|cbga``); the link uses only
that interface. One thread does everything in turn, so nothing here needs a lock: read one
data round and run the robot's behaviours (`RobotAgent.step`), then let the member receive,
bid or plan, and report (`step`). The member offers the robot's resource subjects (none
while it charges), scores or plans tasks with what the robot says of itself (`RobotHooks`:
its task metrics, where it is, its nominal speed), says which task to execute next
(`on_start`/`on_stop`), and hears their completion or failure. With MURDOCH (a `Node`) the
node adds ``idle`` while it holds no contract and bids with the task metrics. A running
task that says which tasks it needs (the box watcher's ``need`` events) has them auctioned
as its sub-tasks by this robot's own node (MURDOCH only). Time is simulation time from the
robot's data.

In a lockstep run (`TickSync`) the node acts on the team's datagrams only at the tick
boundary, in tick order, and the robot declares how many it sent before it asks for the
next round, so what it does repeats exactly.
"""

from __future__ import annotations

import json
import logging
import math
import random
import threading
from collections import deque
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import IO, Any, Protocol

from behaviors.events import TASK_DONE, TASK_FAILED, TASK_STOPPED, Event, EventSink
from behaviors.params import ParamError
from behaviors.task_kinds import task_kinds
from murdoch.allocators import Assignment, RobotHooks, allocator
from murdoch.auction.messages import Announce, AuctionEvent, Outcome
from murdoch.auction.timing import SUB_TASK
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.user_agent import RandomizedBackoff
from player_server.protocol.team_clock import Declaration, decode_table

log = logging.getLogger("murdoch-robot.link")


class AgentTime(Protocol):
    @property
    def time_s(self) -> float: ...


class LinkedAgent(Protocol):
    """What the link needs from the robot it allocates for (`behaviors.agent.RobotAgent`)."""

    @property
    def name(self) -> str: ...

    @property
    def ticks(self) -> int: ...

    def subjects(self) -> frozenset[str]: ...

    def status(self) -> AgentTime: ...

    def evaluate(self, task: str, params: Mapping[str, object]) -> float | None: ...

    def start_task(self, task: str, params: Mapping[str, object], task_id: str = "") -> None: ...

    def stop_task(self, reason: str = "stopped") -> None: ...

    def step(self) -> None: ...


class EventSource(Protocol):
    """Where the robot's behaviour events come from (`behaviors.events.EventLog`)."""

    def add_sink(self, sink: EventSink) -> None: ...


class ClockChannel(Protocol):
    """The team clock device: the table of datagram counts in, this robot's count out."""

    @property
    def data(self) -> bytes: ...

    def send(self, data: bytes) -> None: ...


class SentCounts(Protocol):
    @property
    def sent_count(self) -> int: ...

    @property
    def sender_key(self) -> str: ...


class TickTransport(Protocol):
    """A transport that holds datagrams until the tick they belong to (`murdoch.multicast`)."""

    @property
    def core(self) -> SentCounts: ...

    def settle_tick(self, tick: int, table: Mapping[str, int], *, wait_clock: Clock,
                    give_up_after_s: float = 60.0) -> int: ...


class SharedTables:
    """Team clock tables decoded once per process: the robots of a host process all get the
    same table bytes at a tick, so the first to see new bytes decodes them and the others get
    the same read-only mapping (the last few kept: robots of one host may be a tick apart).
    Thread-safe; a table that does not decode raises `ValueError` as `decode_table` does."""

    KEEP = 4

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._known: dict[bytes, Mapping[str, int]] = {}

    def decode(self, raw: bytes) -> Mapping[str, int]:
        with self._lock:
            table = self._known.get(raw)
            if table is None:
                table = MappingProxyType(decode_table(raw) if raw else {})
                if len(self._known) >= self.KEEP:
                    del self._known[next(iter(self._known))]
                self._known[raw] = table
            return table


PROCESS_TABLES = SharedTables()
"""The tables of this process's robots (`TickSync`'s default)."""


class TickSync:
    """The robot's side of the lockstep tick protocol (see `murdoch.tick_order`).

    Each tick, after the robot has read its round: the team clock table that came with it
    says how many datagrams every participant sent through the previous tick; the transport
    waits for all of them and acts on them in tick order (`settle_tick`). After the node's
    step, the robot declares its own count (opaque command) before it asks for the next
    round."""

    def __init__(self, clock_proxy: ClockChannel, transport: TickTransport, interval_s: float,
                 wait_clock: Callable[[], float], give_up_after_s: float = 60.0,
                 tables: SharedTables = PROCESS_TABLES) -> None:
        self.proxy = clock_proxy
        self.tables = tables
        self.transport = transport
        self.interval_s = interval_s
        self.wait_clock = wait_clock
        self.give_up_after_s = give_up_after_s
        self._last_declared = -1
        self._raw = b""
        self._table: Mapping[str, int] = MappingProxyType({})

    def tick_of(self, time_s: float) -> int:
        return round(time_s / self.interval_s)

    def settle(self, time_s: float) -> None:
        raw = self.proxy.data
        if raw != self._raw:  # most ticks nobody sent anything: the same table again
            self._table = self.tables.decode(raw)
            self._raw = raw
        table = self._table
        self.transport.settle_tick(self.tick_of(time_s), table, wait_clock=self.wait_clock,
                                   give_up_after_s=self.give_up_after_s)

    def declare(self) -> None:
        core = self.transport.core
        count = core.sent_count
        if count != self._last_declared:
            self.proxy.send(Declaration(core.sender_key, count).encode())
            self._last_declared = count


class MurdochLink:
    """Glue between one `RobotAgent` and its allocator's team member (owner thread only).

    `allocator` names it in `murdoch.allocators.ALLOCATORS`; `team` lists every member of
    the team in a fixed order (the world's robots: consensus allocators index agents by
    it) and `speed_mps` is the robot's nominal speed (0: it does not move); `refine` asks
    for the allocator's refined form (`murdoch-robot --refine`)."""

    def __init__(self, agent: LinkedAgent, transport: Transport, events: EventSource,
                 auction_log: IO[str] | None = None, *, subtask_patience_s: float = 60.0,
                 tick_sync: TickSync | None = None, allocator_name: str = "murdoch",
                 team: tuple[str, ...] = (), speed_mps: float = 0.5,
                 refine: bool = False) -> None:
        self.agent = agent
        self.tick_sync = tick_sync
        self.metric_errors = 0
        self._done_kinds = {TASK_DONE: "done", TASK_FAILED: "failed", TASK_STOPPED: "stopped"}
        self._finished: deque[tuple[str, str, str]] = deque(maxlen=64)
        self._needs: deque[tuple[str, tuple[str, ...]]] = deque(maxlen=64)
        self._heading_rad: float | None = None  # which way the watched box is to go
        self._current: str | None = None
        self._current_params: dict[str, Any] = {}
        self._subtasks: dict[str, str] = {}  # task name -> open sub-task id
        self._patience_s = subtask_patience_s
        self._auction_log = auction_log
        self._kinds = task_kinds()
        events.add_sink(self._on_event)
        self.allocator = allocator(allocator_name, refine=refine)
        hooks = RobotHooks(
            agent.name, frozenset(agent.subjects()), score=self._score,
            knows=lambda name: name in self._kinds, on_start=self._on_start, on_stop=self._on_stop,
            position=self._position, speed_mps=speed_mps, team=team or (agent.name,),
            on_outcome=self._on_outcome, observer=self._observe,
            backoff=RandomizedBackoff(random.Random(agent.name), base_s=2.0, cap_s=10.0),
            pose=self._pose, battery=self._battery,
        )
        self.node: TeamMember = self.allocator.robot(transport, self._now, hooks)

    def _observe(self, event: AuctionEvent) -> None:
        if self._auction_log is not None:
            self._auction_log.write(json.dumps(event.to_dict(), default=str) + "\n")
            self._auction_log.flush()

    def _on_outcome(self, outcome: Outcome) -> None:
        # an outcome of a sub-task this robot announced (e.g. a pushing task for the box)
        if self._subtasks.get(outcome.name) == outcome.task_id:
            del self._subtasks[outcome.name]
        if outcome.status == "unachievable" and outcome.parent == self._current:
            assert self._current is not None
            task_id = self._current
            self._current = None
            self.agent.stop_task(f"sub-task {outcome.name} unachievable")
            self.node.fail(task_id, f"unachievable: nobody could do {outcome.name}")

    def _now(self) -> float:
        return float(self.agent.status().time_s)

    def _position(self) -> tuple[float, float]:
        """Where the robot is (its odometric pose; the origin before the first reading)."""
        snapshot = getattr(self.agent, "snapshot", None)
        pose = getattr(snapshot(), "pose", None) if snapshot is not None else None
        return (0.0, 0.0) if pose is None else (float(pose.x_m), float(pose.y_m))

    def _pose(self) -> tuple[float, float, float]:
        """The odometric pose with its heading (the origin before the first reading)."""
        snapshot = getattr(self.agent, "snapshot", None)
        pose = getattr(snapshot(), "pose", None) if snapshot is not None else None
        if pose is None:
            return (0.0, 0.0, 0.0)
        return (float(pose.x_m), float(pose.y_m), float(pose.yaw_rad))

    def _battery(self) -> float | None:
        """The state of charge as a fraction (None: not known)."""
        percent = float(getattr(self.agent.status(), "battery_percent", math.nan))
        return None if math.isnan(percent) else percent / 100.0

    def _metric(self, announce: Announce) -> float | None:
        return self._score(announce.name, announce.params, announce.task_id)

    def _score(self, name: str, params: Mapping[str, Any], task_id: str) -> float | None:
        """The robot's score for a task; None: it cannot do it (no bid).

        A task the robot does not know, or parameters it refuses, mean no bid; a metric that
        raises on a task it knows is a bug: logged with its traceback and counted
        (`metric_errors`), and the robot does not bid."""
        if name not in self._kinds:
            return None
        try:
            return self.agent.evaluate(name, dict(params))
        except ParamError as exc:  # parameters this robot cannot use: do not bid
            log.info("not bidding on %s %s: %s", name, task_id, exc)
            return None
        except Exception:
            self.metric_errors += 1
            log.exception("the metric of %s raised on %s", name, task_id)
            return None

    def _on_start(self, a: Assignment) -> None:
        try:
            self.agent.start_task(a.name, dict(a.params), a.task_id)
        except ParamError as exc:  # parameters this robot cannot use: the task fails
            log.warning("cannot start %s %s: %s", a.name, a.task_id, exc)
            self._finished.append((a.task_id, "failed", f"bad parameters: {exc}"))
            self._current = a.task_id
            return
        self._current = a.task_id
        self._current_params = dict(a.params)

    def _on_stop(self, a: Assignment, reason: str) -> None:
        if self._current == a.task_id:
            self._current = None
            self.agent.stop_task(reason)
            self._cancel_subtasks(reason)

    def _cancel_subtasks(self, reason: str) -> None:
        for task_id in list(self._subtasks.values()):
            self.node.cancel(task_id, reason)
        self._subtasks.clear()

    def _on_event(self, event: Event) -> None:
        # called from agent.step(), on this same thread
        if event.kind in self._done_kinds and event.task_id:
            reason = dict(event.detail).get("reason", "")
            self._finished.append((event.task_id, self._done_kinds[event.kind], str(reason)))
        elif event.kind == "need" and event.task_id:
            detail = dict(event.detail)
            tasks = detail.get("tasks", ())
            self._needs.append((event.task_id, tuple(str(t) for t in tasks)))
            if isinstance(detail.get("heading_rad"), (int, float)):
                self._heading_rad = float(detail["heading_rad"])

    def _announce_needs(self) -> None:
        """A running task (the box watcher) said which tasks it needs: auction them as its
        sub-tasks, one open auction per task name."""
        while self._needs:
            parent, names = self._needs.popleft()
            if parent != self._current:
                continue
            for name in names:
                if name in self._subtasks or name not in self._kinds:
                    continue
                if not self.allocator.sub_tasks:
                    log.warning("%s: cannot offer sub-task %s under %s", parent, name,
                                self.allocator.name)
                    continue
                spec = self._kinds[name]
                params: dict[str, Any] = {
                    "colour": self._current_params.get("colour", "orange")}
                if self._heading_rad is not None:
                    params["heading_rad"] = round(self._heading_rad, 3)
                sub = SUB_TASK.task(name, spec.subjects, params, duration_s=8.0, timeout_s=60.0,
                                    parent=parent)
                self._subtasks[name] = self.node.announce(sub, patience_s=self._patience_s)

    def step(self) -> None:
        sync = self.tick_sync
        ticks = self.agent.ticks
        self.agent.step()
        if sync is not None and self.agent.ticks != ticks:
            sync.settle(self._now())
        while self._finished:
            task_id, how, reason = self._finished.popleft()
            if task_id != self._current:
                continue  # a task we were told to stop, or not a contract
            self._current = None
            self._cancel_subtasks(f"parent {how}")
            if how == "done":
                self.node.complete(task_id)
            else:
                self.node.fail(task_id, reason or how)
        self._announce_needs()
        subjects = frozenset(self.agent.subjects())
        if subjects != self.node.subjects:
            self.node.set_subjects(subjects)  # none while charging
        self.node.step(0.0)
        if sync is not None:
            sync.declare()

    def close(self) -> None:
        self.node.close()
