"""The robot agent: one robot's control loop and the API the outside world drives it through.

`RobotAgent` owns the robot's I/O, its behaviour runner and its battery manager. Its control
loop (`step()`, or `run()` until stopped) reads one data round per tick, runs the current
task's behaviours on their threads, arbitrates, and sends one velocity command. Everything
else talks to it through thread-safe calls that take effect at the next tick:

- `subjects()`: the resource subjects it currently offers (none while charging);
- `evaluate(task, params)`: this robot's fitness for a task instance (None = cannot bid);
- `start_task(task, params, task_id)` / `stop_task()`;
- `status()`: idle / working / charging, the current task, its progress, sim time;
- events (task start/finish/fail, alarms, needs, charging) go to the `EventLog`.

Time is simulation time, taken from the data timestamps.
"""

from __future__ import annotations

import collections
import logging
import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, Protocol

from behaviors import events as ev
from behaviors.battery import (
    BatteryAction,
    BatteryPhase,
    BatteryPolicy,
    BatteryState,
    battery_step,
)
from behaviors.events import Event, EventLog
from behaviors.library import TaskSpec
from behaviors.params import ParamError
from behaviors.profile import RobotProfile
from behaviors.runner import BehaviourFailed, BehaviourRunner, BehaviourStalled
from behaviors.snapshot import EMPTY, Mark, Snapshot, slot_maker
from behaviors.task import TaskExecution
from behaviors.task_kinds import task_kind as task_spec

logger = logging.getLogger(__name__)

AgentState = Literal["idle", "working", "charging"]


class RobotIO(Protocol):
    """The robot's devices as the agent sees them (implemented over the Player client)."""

    def read(self, mark: Mark | None) -> Snapshot:
        """Block for the next data round; return it as a snapshot carrying `mark`."""
        ...

    def command(self, vx_mps: float, vyaw_radps: float) -> None: ...

    def close(self) -> None: ...


@dataclass(frozen=True, slots=True)
class AgentStatus:
    robot: str
    state: AgentState
    time_s: float
    task: str = ""
    task_id: str = ""
    stage: str = ""
    progress: float = 0.0
    battery_percent: float = math.nan
    subjects: frozenset[str] = frozenset()


_make_status = slot_maker(AgentStatus)
_NO_SUBJECTS: frozenset[str] = frozenset()


@dataclass(frozen=True, slots=True)
class _Start:
    spec: TaskSpec
    params: Mapping[str, object]
    task_id: str


@dataclass(frozen=True, slots=True)
class _Stop:
    reason: str


class RobotAgent:
    def __init__(
        self,
        io: RobotIO,
        profile: RobotProfile,
        *,
        events: EventLog | None = None,
        battery: BatteryPolicy | None = None,
        stall_timeout_s: float = 10.0,
    ) -> None:
        self._io = io
        self.profile = profile
        self.events = events if events is not None else EventLog()
        self._battery_policy = battery
        self._battery = BatteryState()
        self._runner = BehaviourRunner(profile.name, stall_timeout_s)
        self._requests: collections.deque[_Start | _Stop] = collections.deque()
        self._lock = threading.Lock()
        self._snapshot: Snapshot = EMPTY
        self._execution: TaskExecution | None = None
        self._task_name = ""
        self._task_id = ""
        self._internal = False  # the running task is the battery manager's dock/undock
        self._last_time = -math.inf
        self._status = AgentStatus(profile.name, "idle", 0.0, subjects=profile.subjects)
        self._last_outcome = ""
        self._running_key: tuple[int, int] | None = None
        self._closed = False
        self.ticks = 0

    # -- thread-safe API ---------------------------------------------------------------------

    @property
    def name(self) -> str:
        return self.profile.name

    def subjects(self) -> frozenset[str]:
        """Subjects offered now: the device subjects, or none while charging."""
        return self._status.subjects

    def snapshot(self) -> Snapshot:
        return self._snapshot

    def status(self) -> AgentStatus:
        return self._status

    def can_do(self, task: str) -> bool:
        try:
            spec = task_spec(task)
        except ParamError:
            return False
        return spec.subjects <= self.subjects()

    def evaluate(
        self,
        task: str,
        params: Mapping[str, object],
        metrics: Sequence[tuple[str, float]] | None = None,
    ) -> float | None:
        """Score this robot for a task instance from its latest snapshot (higher is better).

        None when it cannot bid (lacks a subject, is charging, or a metric cannot be
        evaluated, e.g. the colour is not in view). `metrics` optionally names the metrics
        and weights to sum, as an announcement does; the default is the task's own.
        """
        spec = task_spec(task)
        if not spec.subjects <= self.subjects():
            return None
        return spec.score(self._snapshot, params, self.profile, metrics)

    def start_task(self, task: str, params: Mapping[str, object], task_id: str = "") -> None:
        """Start `task` at the next tick, replacing any task that is running.

        Raises `ParamError` for an unknown task or missing parameters (checked now).
        """
        spec = task_spec(task)
        spec.build(params, self.profile)  # fail now, in the caller, on bad parameters
        with self._lock:
            self._requests.append(_Start(spec, dict(params), task_id))

    def stop_task(self, reason: str = "stopped") -> None:
        with self._lock:
            self._requests.append(_Stop(reason))

    # -- control loop (owner thread only) ------------------------------------------------------

    def run(self, stop: threading.Event, max_ticks: int | None = None) -> None:
        """Tick until `stop` is set (checked once per tick), then stop the robot and clean up."""
        try:
            while not stop.is_set() and (max_ticks is None or self.ticks < max_ticks):
                self.step()
        finally:
            self.close()

    def step(self) -> None:
        """One tick: read, decide, act."""
        execution = self._execution
        mark = execution.mark if execution is not None else None
        snapshot = self._io.read(mark)
        now = snapshot.time_s
        if now <= self._last_time:
            return  # no new data (free-running server polled faster than it ticks)
        self._last_time = now
        self._snapshot = snapshot
        self.ticks += 1
        self._handle_requests(snapshot, now)
        self._battery_tick(snapshot, now)
        execution = self._execution
        if execution is None:
            self._io.command(0.0, 0.0)
        else:
            if execution.mark is not mark:
                snapshot = snapshot.with_mark(execution.mark)
            self._task_tick(execution, snapshot, now)
        self._publish_status(now)

    def _task_tick(self, execution: TaskExecution, snapshot: Snapshot, now: float) -> None:
        runner = self._runner
        try:
            key = (id(execution), execution.view.stage_index)
            if key != self._running_key:
                runner.set_behaviours(execution.behaviours())
                self._running_key = key
            proposals = runner.tick(snapshot, now)
        except (BehaviourFailed, BehaviourStalled) as exc:
            logger.exception("%s: task %s aborted", self.name, self._task_name)
            runner.close()
            self._running_key = None
            self._io.command(0.0, 0.0)
            self._finish(now, ev.TASK_FAILED, f"{type(exc).__name__}: {exc}")
            return
        stage_before = execution.view.stage_index
        result = execution.step(snapshot, now, proposals)
        self._io.command(result.vx_mps, result.vyaw_radps)
        for kind, detail in result.events:
            self._emit(now, kind, detail)
        if execution.view.stage_index != stage_before and execution.outcome == "running":
            runner.set_behaviours(execution.behaviours())
            self._running_key = (id(execution), execution.view.stage_index)
        if result.outcome == "done":
            self._finish(now, ev.TASK_DONE, result.reason)
        elif result.outcome == "failed":
            self._finish(now, ev.TASK_FAILED, result.reason)

    def _handle_requests(self, snapshot: Snapshot, now: float) -> None:
        if not self._requests:
            return  # a request appended meanwhile is handled at the next tick
        with self._lock:
            requests = list(self._requests)
            self._requests.clear()
        for req in requests:
            if isinstance(req, _Stop):
                if self._execution is not None and not self._internal:
                    self._finish(now, ev.TASK_STOPPED, req.reason)
                continue
            if self._battery.phase is not BatteryPhase.SERVICE:
                self._emit(now, ev.TASK_FAILED, (("reason", "charging"),),
                           task=req.spec.name, task_id=req.task_id)
                continue
            if self._execution is not None:
                self._finish(now, ev.TASK_STOPPED, f"replaced by {req.spec.name}")
            self._begin(req.spec, req.params, req.task_id, snapshot, now, internal=False)

    def _begin(self, spec: TaskSpec, params: Mapping[str, object], task_id: str,
               snapshot: Snapshot, now: float, *, internal: bool) -> None:
        try:
            plan = spec.build(params, self.profile)
        except ParamError as exc:
            self._emit(now, ev.TASK_FAILED, (("reason", str(exc)),), task=spec.name,
                       task_id=task_id)
            return
        self._execution = TaskExecution(plan, now, snapshot)
        self._task_name = spec.name
        self._task_id = task_id
        self._internal = internal
        self._emit(now, ev.TASK_START, tuple(sorted((k, v) for k, v in params.items())))

    def _finish(self, now: float, kind: str, reason: str) -> None:
        execution = self._execution
        progress = execution.progress() if execution is not None else 0.0
        self._emit(now, kind, (("progress", round(progress, 3)), ("reason", reason)))
        self._execution = None
        self._last_outcome = "done" if kind == ev.TASK_DONE else "failed"
        self._runner.set_behaviours(())
        self._running_key = None
        self._io.command(0.0, 0.0)

    def _battery_tick(self, snapshot: Snapshot, now: float) -> None:
        policy = self._battery_policy
        if policy is None:
            return
        outcome = ""
        if self._internal:
            outcome = "running" if self._execution is not None else self._last_outcome
        idle = self._execution is None
        self._battery, action = battery_step(
            policy, self._battery, snapshot.power, now, idle=idle, task_outcome=outcome
        )
        if action is BatteryAction.NONE:
            return
        power = snapshot.power
        percent = round(power.percent, 2) if power is not None else math.nan
        if action is BatteryAction.GO_CHARGE:
            pose = snapshot.pose
            charger = None if pose is None else self.profile.nearest_charger(pose.x_m, pose.y_m)
            if charger is None:
                logger.warning("%s: battery low but no known charger", self.name)
                self._battery = BatteryState()
                return
            self._emit(now, ev.CHARGE_NEEDED, (("charger", charger.name), ("percent", percent)))
            self._begin(task_spec("dock"), {"x": charger.x_m, "y": charger.y_m}, "", snapshot,
                        now, internal=True)
        elif action is BatteryAction.DOCK_FAILED:
            pose = snapshot.pose
            charger = None if pose is None else self.profile.nearest_charger(pose.x_m, pose.y_m)
            if charger is not None:
                self._begin(task_spec("dock"), {"x": charger.x_m, "y": charger.y_m}, "",
                            snapshot, now, internal=True)
        elif action is BatteryAction.CHARGE_STARTED:
            if self._execution is not None:
                self._execution = None
                self._runner.set_behaviours(())
                self._running_key = None
            self._io.command(0.0, 0.0)
            self._emit(now, ev.CHARGE_START, (("percent", percent),), task="")
        elif action is BatteryAction.CHARGE_DONE:
            self._emit(now, ev.CHARGE_END, (("percent", percent),), task="")
            self._begin(task_spec("undock"), {}, "", snapshot, now, internal=True)
        elif action is BatteryAction.RETURN_TO_SERVICE:
            self._internal = False
            self._emit(now, ev.SUBJECTS, (("subjects", sorted(self.profile.subjects)),))

    def _publish_status(self, now: float) -> None:
        execution = self._execution
        charging = self._battery.phase is not BatteryPhase.SERVICE
        state: AgentState
        if charging:
            state = "charging"
        elif execution is not None:
            state = "working"
        else:
            state = "idle"
        power = self._snapshot.power
        self._status = _make_status(
            self.profile.name,
            state,
            now,
            "" if execution is None else self._task_name,
            "" if execution is None else self._task_id,
            "" if execution is None else execution.view.stage_name,
            0.0 if execution is None else execution.progress(),
            math.nan if power is None else power.percent,
            _NO_SUBJECTS if charging else self.profile.subjects,
        )

    def _emit(self, now: float, kind: str, detail: tuple[tuple[str, Any], ...] = (),
              task: str | None = None, task_id: str | None = None) -> None:
        self.events.emit(
            Event(
                now,
                self.name,
                kind,
                self._task_name if task is None else task,
                self._task_id if task_id is None else task_id,
                detail,
            )
        )

    def close(self) -> None:
        """Stop the robot, join the behaviour threads, close the I/O. Idempotent.

        Closing the connection promptly matters in lockstep: a robot that stops asking for
        data would otherwise hold the simulation clock for everyone else.
        """
        if self._closed:
            return
        self._closed = True
        self._runner.close()
        try:
            self._io.command(0.0, 0.0)
        except Exception as exc:  # the connection may already be gone; nothing else to do
            logger.warning("%s: could not send the final stop command: %s", self.name, exc)
        try:
            self._io.close()
        except Exception as exc:
            logger.warning("%s: could not close its connection: %s", self.name, exc)
