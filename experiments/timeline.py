"""What each robot was doing, derived from events: states for the viewer, intervals for plots.

A robot is ``failed`` (down: its process was killed or it was switched off), else
``charging``, else ``working`` (it holds a task it was awarded), else ``idle``.
`RobotStateTracker.apply` folds one event at a time and returns the robots whose state or label
changed, so the live view and the batch functions share the same rules.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from experiments import events as ev
from worlds.colours import colour_name, parse_colour

IDLE = "idle"
WORKING = "working"
CHARGING = "charging"
FAILED = "failed"
STATES: tuple[str, ...] = (IDLE, WORKING, CHARGING, FAILED)


# a killed robot and a switched-off one are down alike until restarted / switched on
_DOWN = frozenset((ev.ROBOT_FAILURE, ev.ROBOT_SWITCH_OFF))
_UP = frozenset((ev.ROBOT_RESTART, ev.ROBOT_SWITCH_ON))


@dataclass(frozen=True, slots=True)
class RobotState:
    state: str
    label: str  # "" unless working: "<task kind> <task id>"
    task: str | None = None
    target: str = ""  # what the task is about: "red object", "blue box", "spot (1.0, 2.0)"
    target_colour: int | None = None  # the colour the target is named by, if any

    @property
    def view_label(self) -> str:
        """The task and its target, for the live view: "cleanup: blue box"."""
        if not self.label:
            return ""
        kind = self.label.split(" ", 1)[0]
        return f"{kind}: {self.target}" if self.target else self.label


@dataclass(frozen=True, slots=True)
class Interval:
    robot: str
    start_s: float
    end_s: float
    state: str
    label: str
    task: str | None
    target: str = ""
    target_colour: int | None = None


@dataclass(slots=True)
class _Robot:
    task: str | None = None
    charging: bool = False
    failed: bool = False


@dataclass(slots=True)
class RobotStateTracker:
    robots: dict[str, _Robot] = field(default_factory=dict)
    task_kinds: dict[str, str] = field(default_factory=dict)
    task_targets: dict[str, str] = field(default_factory=dict)
    task_target_colours: dict[str, int] = field(default_factory=dict)

    def add_robot(self, robot: str) -> None:
        self.robots.setdefault(robot, _Robot())

    def state_of(self, robot: str) -> RobotState:
        r = self.robots[robot]
        if r.failed:
            return RobotState(FAILED, "")
        if r.charging:
            return RobotState(CHARGING, "")
        if r.task is not None:
            return RobotState(WORKING, self.label(r.task), r.task,
                              self.task_targets.get(r.task, ""),
                              self.task_target_colours.get(r.task))
        return RobotState(IDLE, "")

    def label(self, task: str) -> str:
        kind = self.task_kinds.get(task, "")
        return f"{kind} {task}".strip()

    def states(self) -> dict[str, RobotState]:
        return {name: self.state_of(name) for name in self.robots}

    def apply(self, event: Mapping[str, Any]) -> dict[str, RobotState]:
        """Fold one event; returns the new state of every robot it changed."""
        kind = event.get("kind")
        touched: list[str] = []
        if kind == ev.TASK_INTRODUCED:
            self.task_kinds[str(event["task"])] = str(event["task_kind"])
            params = event.get("params")
            if isinstance(params, Mapping):
                target = target_text(str(event["task_kind"]), params)
                if target:
                    self.task_targets[str(event["task"])] = target
                colour = target_colour(params)
                if colour is not None:
                    self.task_target_colours[str(event["task"])] = colour
        elif kind == ev.AWARD:
            task, robot = str(event["task"]), str(event["robot"])
            if "task_kind" in event:
                self.task_kinds.setdefault(task, str(event["task_kind"]))
            touched += self._release(task)
            self.add_robot(robot)
            self.robots[robot].task = task
            touched.append(robot)
        elif kind in (ev.TASK_OUTCOME, ev.REALLOCATION):
            touched += self._release(str(event["task"]))
        elif kind in (ev.CHARGE_START, ev.CHARGE_END):
            robot = str(event["robot"])
            self.add_robot(robot)
            self.robots[robot].charging = kind == ev.CHARGE_START
            touched.append(robot)
        elif kind in _DOWN or kind in _UP:
            robot = str(event["robot"])
            self.add_robot(robot)
            r = self.robots[robot]
            r.failed = kind in _DOWN
            r.task = None
            r.charging = False
            touched.append(robot)
        return {name: self.state_of(name) for name in dict.fromkeys(touched)}

    def _release(self, task: str) -> list[str]:
        released = []
        for name, r in self.robots.items():
            if r.task == task:
                r.task = None
                released.append(name)
        return released


def target_colour(params: Mapping[str, Any]) -> int | None:
    """The colour a task's target is named by (its ``colour`` parameter), if it has one."""
    value = params.get("colour")
    if value is None:
        return None
    try:
        return parse_colour(value)
    except ValueError:
        return None


def target_text(task_kind: str, params: Mapping[str, Any]) -> str:
    """What a task is about, from its parameters: the object to track or watch, the box to
    clean up, the spot to guard; a colour by its name ("cleanup: orange box")."""
    value = target_colour(params)
    colour = colour_name(value) if value is not None else params.get("colour")
    if task_kind == "cleanup":
        return f"{colour} box" if colour else "a box"
    if task_kind == "watch-box":
        goal = target_colour({"colour": params.get("goal_colour")})
        goal_name = colour_name(goal) if goal is not None else params.get("goal_colour")
        box = f"{colour} box" if colour else "the box"
        return f"{box} to the {goal_name} marker" if goal_name else box
    if task_kind in ("object-tracking", "monitor-object", "sentry-duty"):
        what = f"{colour} object" if colour else ""
        if "x" in params and "y" in params:
            try:
                spot = f"spot ({float(params['x']):.1f}, {float(params['y']):.1f})"
            except (TypeError, ValueError):
                spot = ""
            return f"{what} at {spot}".strip() if what and spot else what or spot
        return what
    if "x" in params and "y" in params:
        try:
            return f"({float(params['x']):.1f}, {float(params['y']):.1f})"
        except (TypeError, ValueError):
            return ""
    return ""


def robot_intervals(
    events: Iterable[Mapping[str, Any]], robots: Iterable[str] = (), end_s: float | None = None
) -> dict[str, list[Interval]]:
    """Every robot's states as consecutive intervals from its first mention to `end_s`
    (default: the last event's time)."""
    tracker = RobotStateTracker()
    current: dict[str, tuple[float, RobotState]] = {}
    out: dict[str, list[Interval]] = {}
    last_t = 0.0
    for name in robots:
        tracker.add_robot(name)
        current[name] = (0.0, tracker.state_of(name))
        out[name] = []
    for event in events:
        t = float(event["t"])
        last_t = max(last_t, t)
        for name, state in tracker.apply(event).items():
            if name not in current:
                current[name] = (0.0, RobotState(IDLE, ""))
                out[name] = []
            start, old = current[name]
            if state == old:
                continue
            if t > start:
                out[name].append(Interval(name, start, t, old.state, old.label, old.task,
                                          old.target, old.target_colour))
            current[name] = (t, state)
    stop = last_t if end_s is None else end_s
    for name, (start, state) in current.items():
        if stop > start:
            out[name].append(Interval(name, start, stop, state.state, state.label, state.task,
                                      state.target, state.target_colour))
    return out
