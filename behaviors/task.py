"""Tasks: staged, concurrent compositions of parameterised basis behaviours.

A `TaskPlan` is a sequence of `Stage`s; each stage runs its behaviours concurrently and
arbitrates their proposals into one command. A stage ends when its `until` condition holds
(then the next stage starts, or the task is done after the last one, or the plan loops back
to `repeat_from`), and the task as a whole ends when `done` or `failed` holds or a timeout
passes. `TaskExecution` steps a plan tick by tick; it is single-threaded and pure apart from
its own bookkeeping, so it is tested without threads or servers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from behaviors.arbiter import Arbiter, ArbiterMode, Layer
from behaviors.proposal import Proposal
from behaviors.snapshot import Mark, Snapshot, slot_maker


class TickView:
    """What conditions and observers see on a tick. Owned and reused by one execution."""

    __slots__ = (
        "loops",
        "memo",
        "now",
        "signal_since",
        "signals",
        "snapshot",
        "stage_index",
        "stage_name",
        "stage_started_s",
        "task_started_s",
    )

    def __init__(self, task_started_s: float) -> None:
        self.snapshot: Snapshot = Snapshot(time_s=task_started_s)
        self.now = task_started_s
        self.signals: dict[str, float] = {}
        self.signal_since: dict[str, float] = {}
        self.task_started_s = task_started_s
        self.stage_started_s = task_started_s
        self.stage_index = 0
        self.stage_name = ""
        self.loops = 0
        self.memo: dict[str, Any] = {}

    @property
    def task_elapsed_s(self) -> float:
        return self.now - self.task_started_s

    @property
    def stage_elapsed_s(self) -> float:
        return self.now - self.stage_started_s

    def held_s(self, signal: str) -> float:
        """How long `signal` has been raised without a break (0 when it is not raised now)."""
        since = self.signal_since.get(signal)
        return 0.0 if since is None else self.now - since


Condition = Callable[[TickView], bool]
Observer = Callable[[TickView], Sequence[tuple[str, Mapping[str, Any]]]]


def signal(name: str, held_s: float = 0.0) -> Condition:
    """True once `name` has been raised by some behaviour for at least `held_s`."""

    def check(view: TickView) -> bool:
        return name in view.signals and view.held_s(name) >= held_s - 1e-9

    return check


def elapsed(duration_s: float) -> Condition:
    """True once the task has run for `duration_s`."""
    return lambda view: view.task_elapsed_s >= duration_s


def stage_elapsed(duration_s: float) -> Condition:
    return lambda view: view.stage_elapsed_s >= duration_s


def any_of(*conditions: Condition) -> Condition:
    return lambda view: any(c(view) for c in conditions)


def never(view: TickView) -> bool:
    return False


@dataclass(frozen=True, slots=True)
class Stage:
    name: str
    layers: tuple[Layer, ...]
    mode: ArbiterMode = "priority"
    until: Condition = never
    timeout_s: float = math.inf
    on_timeout: Literal["fail", "done", "next"] = "fail"
    alarms: tuple[tuple[str, str], ...] = ()  # (signal, event kind) raised on a rising edge


@dataclass(frozen=True, slots=True)
class TaskPlan:
    name: str
    stages: tuple[Stage, ...]
    repeat_from: int | None = None
    done: Condition = never
    failed: Condition = never
    timeout_s: float = math.inf
    progress: Callable[[TickView], float] | None = None
    observe: Observer | None = None
    max_speed_mps: float = 0.5
    max_turn_radps: float = 1.2

    def __post_init__(self) -> None:
        if not self.stages:
            raise ValueError(f"task {self.name!r} has no stages")


Outcome = Literal["running", "done", "failed"]


@dataclass(frozen=True, slots=True)
class TickResult:
    vx_mps: float
    vyaw_radps: float
    outcome: Outcome
    reason: str = ""
    events: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = field(default=())


_NO_EVENTS: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()
_make_result = slot_maker(TickResult)


class TaskExecution:
    """Steps one `TaskPlan`: stage changes, signals, events, done/failed, progress."""

    def __init__(self, plan: TaskPlan, started_s: float, snapshot: Snapshot | None = None):
        self.plan = plan
        self.view = TickView(started_s)
        self._arbiters = tuple(
            Arbiter(s.layers, s.mode, plan.max_speed_mps, plan.max_turn_radps)
            for s in plan.stages
        )
        self.outcome: Outcome = "running"
        self.reason = ""
        self._spare_signals: dict[str, float] = {}
        self._mark = Mark(
            started_s,
            None if snapshot is None else snapshot.pose,
            None if snapshot is None else snapshot.laser,
        )
        self._enter(0, started_s, snapshot)

    @property
    def stage(self) -> Stage:
        return self.plan.stages[self.view.stage_index]

    @property
    def mark(self) -> Mark:
        return self._mark

    def behaviours(self) -> tuple[Any, ...]:
        return tuple(layer.behaviour for layer in self.stage.layers)

    def progress(self) -> float:
        if self.outcome == "done":
            return 1.0
        fn = self.plan.progress
        if fn is None:
            return 0.0
        value = fn(self.view)
        if not math.isfinite(value):
            return 0.0
        return min(1.0, max(0.0, value))

    def _enter(self, index: int, now: float, snapshot: Snapshot | None) -> None:
        view = self.view
        view.stage_index = index
        view.stage_name = self.plan.stages[index].name
        view.stage_started_s = now
        self._mark = Mark(
            now,
            None if snapshot is None else snapshot.pose,
            None if snapshot is None else snapshot.laser,
        )

    def step(self, snapshot: Snapshot, now: float, proposals: Sequence[Proposal]) -> TickResult:
        """Account for one tick whose proposals came from `self.behaviours()`."""
        if self.outcome != "running":
            return TickResult(0.0, 0.0, self.outcome, self.reason)
        view = self.view
        view.snapshot = snapshot
        view.now = now
        stage = self.stage
        # Swap this tick's and last tick's signal tables (no allocation per tick).
        previous, signals = view.signals, self._spare_signals
        self._spare_signals = previous
        signals.clear()
        view.signals = signals
        for p in proposals:
            if p.signal:
                signals[p.signal] = p.value
        since = view.signal_since
        if len(since) != len(signals) or any(name not in signals for name in since):
            for name in [n for n in since if n not in signals]:
                del since[name]
        events: list[tuple[str, tuple[tuple[str, Any], ...]]] = []
        for name, value in signals.items():
            if name not in since:
                since[name] = now
            if name not in previous and stage.alarms:
                for sig, kind in stage.alarms:
                    if sig == name:
                        events.append((kind, (("signal", name), ("value", value))))
        if self.plan.observe is not None:
            for kind, values in self.plan.observe(view):
                events.append((kind, tuple(sorted(values.items()))))
        vx, vyaw = self._arbiters[view.stage_index].combine(proposals)
        outcome, reason = self._advance(stage, snapshot, now, events)
        if outcome != "running":
            self.outcome, self.reason = outcome, reason
            vx = vyaw = 0.0
        return _make_result(vx, vyaw, outcome, reason, tuple(events) if events else _NO_EVENTS)

    def _advance(
        self,
        stage: Stage,
        snapshot: Snapshot,
        now: float,
        events: list[tuple[str, tuple[tuple[str, Any], ...]]],
    ) -> tuple[Outcome, str]:
        plan = self.plan
        view = self.view
        if plan.failed(view):
            return "failed", "failure condition"
        if plan.done(view):
            return "done", "done condition"
        if view.task_elapsed_s >= plan.timeout_s:
            return "failed", "task timeout"
        finished = stage.until(view)
        if not finished and view.stage_elapsed_s >= stage.timeout_s:
            if stage.on_timeout == "fail":
                return "failed", f"stage {stage.name} timed out"
            if stage.on_timeout == "done":
                return "done", f"stage {stage.name} timed out"
            finished = True
        if not finished:
            return "running", ""
        nxt = view.stage_index + 1
        if nxt >= len(plan.stages):
            if plan.repeat_from is None:
                return "done", f"stage {stage.name} complete"
            nxt = plan.repeat_from
            view.loops += 1
        self._enter(nxt, now, snapshot)
        view.signal_since.clear()
        events.append(("stage", (("stage", plan.stages[nxt].name),)))
        return "running", ""
