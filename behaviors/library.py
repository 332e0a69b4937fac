"""The task library: the paper's tasks as behaviour compositions, with subjects and metrics.

Every task has a name (the shared vocabulary), the resource subjects a robot needs for it,
default parameters, a builder that turns parameters into a `TaskPlan` for this robot, and
weighted metrics that score this robot's fitness for a task instance (higher is better).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from behaviors.arbiter import Layer
from behaviors.basis import (
    BackOff,
    BoxAlignmentFromLaser,
    Cruise,
    CruiseOnHeading,
    DockAtCharger,
    GoalFromCamera,
    Hold,
    KeepDistanceToColour,
    PushWithBumpers,
    ServoToLocation,
    TurnAbout,
    ViewOfEnd,
    VisualServoToColour,
    WatchForMotionWithLaser,
)
from behaviors.group_watch import build_watch_side
from behaviors.metrics import (
    WeightedMetric,
    battery_fraction,
    colour_alignment,
    colour_proximity,
    colour_visible,
    constant,
    negative_distance,
    place_distance,
    spare_resources,
    unseen_fallback,
    weighted_sum,
)
from behaviors.params import ParamError, colour_of, number
from behaviors.plan_parts import avoid_layers as _avoid
from behaviors.plan_parts import distance_progress as _distance_progress
from behaviors.plan_parts import elapsed_progress as _elapsed_progress
from behaviors.plan_parts import search as _search
from behaviors.profile import OVERHEAD_CAMERA, RobotProfile
from behaviors.snapshot import Snapshot, wrap_angle
from behaviors.task import Stage, TaskPlan, TickView, any_of, elapsed, signal, stage_elapsed
from behaviors.task_place import Place, camera_place, default_place

Params = Mapping[str, object]
Builder = Callable[[Params, RobotProfile], TaskPlan]

# Optional terms of every task's metric (`RobotProfile.bid_terms`, `murdoch-robot --metric`):
# "distance", the paper's example metric (metres to where the task is, shorter is better),
# and "specialist", the paper's proposal that a robot with fewer resources raise its score so
# that generalists stay free for later tasks. The specialist weight exceeds the spread of
# every other term (visibility 1, battery 0.5, distance over a 16 m lab 4): a specialist
# always defeats a generalist, as proposed.
BID_TERMS = ("distance", "specialist")
DISTANCE_WEIGHT = 0.25
SPECIALIST_WEIGHT = 6.0

# Where a pusher aims across the box's width (as seen from behind it).
AIM_LEFT = 0.2
AIM_MIDDLE = 0.5
AIM_RIGHT = 0.8


@dataclass(frozen=True)
class TaskSpec:
    """A task kind: its name, the resource subjects a robot needs, its parameters (defaults
    and required ones), the behaviour composition that executes it on a robot
    (`build_plan`), the metrics a robot bids with, how long one runs (`duration_param`) and
    where one takes place (`place`)."""

    name: str
    subjects: frozenset[str]
    defaults: Mapping[str, object]
    required: tuple[str, ...]
    build_plan: Builder
    metrics: tuple[WeightedMetric, ...]
    description: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)
    duration_param: str | None = "duration_s"
    """The parameter holding how long a task of this kind runs, in simulated seconds (its
    announcement's duration; the contract times out 600 s after it); None: a task that runs
    until it is done and is only ever a sub-task."""
    place: Place = default_place
    """Where a task of this kind takes place (`behaviors.task_place`)."""

    def duration_s(self, params: Params) -> float:
        """How long a task with `params` runs (0: the kind names no duration)."""
        if self.duration_param is None:
            return 0.0
        return number(self.resolve(params), self.duration_param)

    def resolve(self, params: Params) -> dict[str, object]:
        missing = [k for k in self.required if k not in params]
        if missing:
            raise ParamError(f"task {self.name!r}: missing parameter(s) {', '.join(missing)}")
        merged = dict(self.defaults)
        merged.update(params)
        return merged

    def build(self, params: Params, profile: RobotProfile) -> TaskPlan:
        return self.build_plan(self.resolve(params), profile)

    def metric_names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.metrics)

    def score(
        self,
        snapshot: Snapshot,
        params: Params,
        profile: RobotProfile,
        weights: Sequence[tuple[str, float]] | None = None,
    ) -> float | None:
        """Weighted sum of this task's metrics, or None if this robot cannot do it now.

        `weights` (metric name, weight) pairs, as an announcement names them, replace the
        task's default weights; naming a metric the task does not have is a `ParamError`.
        """
        if not self.subjects <= profile.subjects:
            return None
        metrics = self.metrics
        if weights:
            by_name = {m.name: m for m in self.metrics}
            unknown = [n for n, _ in weights if n not in by_name]
            if unknown:
                raise ParamError(
                    f"task {self.name!r} has no metric {', '.join(unknown)}; "
                    f"known: {', '.join(by_name)}"
                )
            metrics = tuple(WeightedMetric(n, by_name[n].fn, w) for n, w in weights)
        if profile.bid_terms:
            metrics = (*metrics, *bid_terms(self, profile.bid_terms))
        return weighted_sum(metrics, snapshot, self.resolve(params), profile)


def parse_bid_terms(text: str) -> tuple[str, ...]:
    """'distance,specialist' -> ('distance', 'specialist'); '' or 'default' -> ().
    ParamError names the unknown term and the known ones."""
    terms = tuple(t.strip() for t in text.split(",") if t.strip() and t.strip() != "default")
    unknown = [t for t in terms if t not in BID_TERMS]
    if unknown:
        raise ParamError(f"unknown metric term(s) {', '.join(unknown)}; known: "
                         f"{', '.join(BID_TERMS)} (comma-separated), or default")
    return tuple(dict.fromkeys(terms))


def bid_terms(spec: TaskSpec, terms: Sequence[str]) -> tuple[WeightedMetric, ...]:
    """The optional metric terms `terms` for task `spec`."""
    out = []
    if "distance" in terms:
        out.append(WeightedMetric("distance", place_distance(), DISTANCE_WEIGHT))
    if "specialist" in terms:
        out.append(WeightedMetric("specialist", spare_resources(spec.subjects, RESOURCES),
                                  SPECIALIST_WEIGHT))
    return tuple(out)


# --- goto-goal ------------------------------------------------------------------------------


def build_goto(p: Params, profile: RobotProfile) -> TaskPlan:
    x, y = number(p, "x"), number(p, "y")
    tolerance = number(p, "tolerance_m")
    servo = ServoToLocation(x, y, tolerance_m=tolerance, max_speed_mps=number(p, "speed_mps"))
    layers = (*_avoid(profile, number(p, "safe_range_m")), Layer(servo, 1))
    return TaskPlan(
        "goto-goal",
        (Stage("go", layers, until=signal("at-goal")),),
        timeout_s=number(p, "timeout_s"),
        progress=_distance_progress(x, y),
    )


# --- pushing --------------------------------------------------------------------------------


def _close_to_box(colour: int, near_m: float, recent_s: float) -> Callable[[TickView], bool]:
    """The approach is over: touching the box, or it just went out of view up close.

    The camera loses a long box when the robot is near one of its ends, so losing it within
    `recent_s` of having seen it nearer than `near_m` counts as having arrived.
    """

    def check(view: TickView) -> bool:
        signals = view.signals
        if "contact" in signals or "reached" in signals:
            return True
        memo = view.memo
        if "seen" in signals:
            memo["seen_range_m"] = signals["seen"]
            memo["seen_at_s"] = view.now
            return False
        return (memo.get("seen_range_m", math.inf) < near_m
                and view.now - memo.get("seen_at_s", -math.inf) <= recent_s)

    del colour
    return check


def _push_builder(name: str, aim: float) -> Builder:
    """Approach the end to push (visual servo on the box colour), push straight ahead with
    the bumpers for `duration_s`, then back off so that the box is in view for the next bid."""

    def build(p: Params, profile: RobotProfile) -> TaskPlan:
        colour = colour_of(p["colour"])
        duration = number(p, "duration_s")
        speed = number(p, "speed_mps")
        backoff = number(p, "backoff_s")
        near = number(p, "approach_m")
        side_avoid = _avoid(profile, 0.25, ignore_half_angle_rad=math.radians(60.0))
        approach: tuple[Layer, ...] = (
            *side_avoid,
            Layer(VisualServoToColour(colour, aim_fraction=aim, speed_mps=speed,
                                      stop_range_m=near * 0.5,
                                      align_tolerance_rad=math.radians(10.0)), 1),
            Layer(_search(profile), 0),
        )
        heading = p.get("heading_rad")
        if heading is None:
            push: tuple[Layer, ...] = (*side_avoid, Layer(Cruise(speed_mps=speed), 0))
        else:
            # The watcher said which way the box is to go: push that way, whatever angle
            # the approach ended at (never sideways into the box).
            push = (*side_avoid,
                    Layer(CruiseOnHeading(number(p, "heading_rad"), speed_mps=speed), 1))
        if profile.has("bumper"):
            approach = (*approach, Layer(PushWithBumpers(speed_mps=speed), 1))
        return TaskPlan(
            name,
            (
                # Too close to see the end to push (e.g. it is the far end): get a view.
                Stage("view", (Layer(ViewOfEnd(colour, aim, min_range_m=near * 1.8,
                                               speed_mps=speed), 1),),
                      until=signal("in-view"), timeout_s=12.0, on_timeout="next"),
                Stage("approach", approach, until=_close_to_box(colour, near, 1.0),
                      timeout_s=number(p, "lost_s")),
                Stage("push", push, until=stage_elapsed(duration)),
                # Step back from the box so that it is in view again for the next bid.
                Stage("back-off", (Layer(BackOff(duration_s=backoff, turn_radps=0.0), 1),),
                      until=signal("backed-off")),
            ),
            progress=_elapsed_progress(duration + backoff),
        )

    return build


def _push_metrics(aim: float) -> tuple[WeightedMetric, ...]:
    return (
        WeightedMetric("alignment", unseen_fallback(colour_alignment(aim), -math.pi), 1.0),
        WeightedMetric("proximity", unseen_fallback(colour_proximity(), -3.0), 0.3),
    )


def _push_task(name: str, aim: float, description: str) -> TaskSpec:
    """A pushing task: the box's end at `aim` (`AIM_LEFT`, `AIM_MIDDLE`, `AIM_RIGHT`)."""
    return TaskSpec(
        name, frozenset({"mobile", "camera"}),
        {"duration_s": 5.0, "speed_mps": 0.2, "lost_s": 20.0, "backoff_s": 3.0,
         "approach_m": 0.8}, ("colour",),
        _push_builder(name, aim), _push_metrics(aim), description, duration_param=None,
    )


# --- watch-box (the watcher) ----------------------------------------------------------------


def needed_push(box_heading_error_rad: float, tolerance_rad: float) -> tuple[str, ...]:
    """Which pushing tasks move the box towards the goal now.

    A box turned counter-clockwise of the goal direction (positive error) has its left end
    (as seen by the pushers) lagging, so pushing only the left end turns it back clockwise;
    a box in line with the goal is pushed at both ends at once.
    """
    if box_heading_error_rad > tolerance_rad:
        return ("push-left-end",)
    if box_heading_error_rad < -tolerance_rad:
        return ("push-right-end",)
    return ("push-left-end", "push-right-end")


def build_watch_box(p: Params, profile: RobotProfile) -> TaskPlan:
    """The watcher faces the goal (camera) with the box behind it (rear-facing laser).

    It drives towards the goal marker while the box is within `lead_m` behind it, waits when
    the box falls back, and compares the box's heading (from the face its laser sees) with
    the goal's bearing (from its camera) to decide which pushing task is needed next.
    """
    box_colour = colour_of(p["colour"])
    goal = colour_of(p["goal_colour"])
    lead = number(p, "lead_m")
    tolerance = number(p, "tolerance_rad")
    period = number(p, "need_period_s")
    duration = number(p, "duration_s")
    # while it waits for the box it keeps turning until the goal is in view (the goal may
    # have moved or changed), in the direction its search turns
    aligner = BoxAlignmentFromLaser(
        centre_rad=number(p, "laser_sector_rad"), max_range_m=lead + 2.5, wait_range_m=lead,
        look_for=goal, look_turn_radps=0.4 if profile.seed % 2 == 0 else -0.4,
    )
    layers = (
        Layer(aligner, 2),
        Layer(GoalFromCamera(goal, speed_mps=number(p, "speed_mps"),
                             arrive_range_m=number(p, "arrive_m")), 1),
        Layer(_search(profile, 0.0), 0),
    )
    del box_colour  # the box is found by shape (laser); its colour is for the pushers

    def observe(view: TickView) -> list[tuple[str, Mapping[str, Any]]]:
        signals = view.signals
        goal_bearing = signals.get("goal", signals.get("goal-reached"))
        if goal_bearing is None or "box" not in signals:
            return []
        face = aligner.face(view.snapshot, view.now)
        if face is None:
            return []
        memo = view.memo
        # The face normal points from the watcher into the box; the box travels the other way.
        error = wrap_angle(face.normal_rad + math.pi - goal_bearing)
        need = needed_push(error, tolerance)
        pose = view.snapshot.pose
        # Which way the box is to travel, in the odometry frame the pushers share (toward the
        # goal): the pushers push along it.
        heading = None if pose is None else wrap_angle(pose.yaw_rad + goal_bearing)
        memo["box_heading_error_rad"] = error
        memo["box_range_m"] = face.range_m
        if need == memo.get("need") and view.now - memo.get("need_at_s", -math.inf) < period:
            return []
        memo["need"] = need
        memo["need_at_s"] = view.now
        detail: dict[str, Any] = {"tasks": list(need),
                                  "box_heading_error_rad": round(error, 4),
                                  "box_range_m": round(face.range_m, 3)}
        if heading is not None:
            detail["heading_rad"] = round(heading, 4)
        return [("need", detail)]

    return TaskPlan(
        "watch-box",
        (Stage("lead", layers, until=signal("goal-reached", held_s=1.0)),),
        done=elapsed(duration),
        observe=observe,
        progress=_elapsed_progress(duration),
    )


# --- object-tracking, sentry-duty, cleanup, monitor-object ------------------------------------


def build_tracking(p: Params, profile: RobotProfile) -> TaskPlan:
    colour = colour_of(p["colour"])
    duration = number(p, "duration_s")
    layers = (
        *_avoid(profile, 0.4),
        Layer(KeepDistanceToColour(colour, distance_m=number(p, "distance_m")), 1),
        Layer(_search(profile, 0.1), 0),
    )
    return TaskPlan(
        "object-tracking",
        (Stage("track", layers),),
        done=elapsed(duration),
        progress=_elapsed_progress(duration),
    )


def build_sentry(p: Params, profile: RobotProfile) -> TaskPlan:
    colour = colour_of(p["colour"])
    duration = number(p, "duration_s")
    approach = VisualServoToColour(colour, stop_range_m=number(p, "approach_m"), speed_mps=0.3)
    stages = (
        Stage(
            "find",
            (*_avoid(profile, 0.4, prefer_laser=True), Layer(approach, 1),
             Layer(_search(profile, 0.05), 0)),
            until=signal("reached"),
            timeout_s=number(p, "search_s"),
        ),
        Stage("turn-about", (Layer(TurnAbout(math.pi), 1),), until=signal("turned"),
              timeout_s=30.0),
        Stage(
            "watch",
            (Layer(WatchForMotionWithLaser(threshold_m=number(p, "threshold_m")), 1),),
            alarms=(("motion", "alarm"),),
        ),
    )
    return TaskPlan(
        "sentry-duty", stages, done=elapsed(duration), progress=_elapsed_progress(duration)
    )


def build_cleanup(p: Params, profile: RobotProfile) -> TaskPlan:
    colour = colour_of(p["colour"])
    duration = number(p, "duration_s")
    boxes = number(p, "boxes")
    seek = (
        *_avoid(profile, 0.35, ignore_half_angle_rad=math.radians(25.0)),
        Layer(VisualServoToColour(colour, speed_mps=0.25), 1),
        Layer(_search(profile, 0.05), 0),
        # Sensing only (gain 0, lowest priority): it raises "contact" when a bumper touches.
        Layer(PushWithBumpers(speed_mps=0.2), -1, gain=0.0),
    )

    def touching_box(view: TickView) -> bool:
        # In contact, with the colour right in front (not, say, a wall).
        return "contact" in view.signals and view.signals.get("seen", math.inf) < 0.6

    push = (
        Layer(PushWithBumpers(speed_mps=0.2), 2),
        Layer(VisualServoToColour(colour, speed_mps=0.2), 1),
    )
    stages = (
        Stage("seek", seek, until=touching_box, timeout_s=number(p, "search_s"),
              on_timeout="done"),
        Stage("push", push, until=signal("blocked", held_s=1.0),
              timeout_s=number(p, "push_s"), on_timeout="next"),
        Stage("back-off", (Layer(BackOff(duration_s=2.0), 1),), until=signal("backed-off")),
        Stage("turn-away", (Layer(TurnAbout(math.pi * 0.75), 1),), until=signal("turned"),
              timeout_s=20.0, on_timeout="next"),
    )
    return TaskPlan(
        "cleanup",
        stages,
        repeat_from=0,
        done=any_of(elapsed(duration), lambda view: view.loops >= boxes),
        progress=lambda view: max(view.loops / boxes if boxes > 0 else 0.0,
                                  view.task_elapsed_s / duration),
    )


def build_monitor(p: Params, profile: RobotProfile) -> TaskPlan:
    raw = p["colours"]
    items = raw.split(",") if isinstance(raw, str) else [raw]
    colours = frozenset(colour_of(c.strip() if isinstance(c, str) else c) for c in items if c)
    duration = number(p, "duration_s")
    period = number(p, "period_s")
    overhead = profile.overhead

    def observe(view: TickView) -> list[tuple[str, Mapping[str, Any]]]:
        cam = view.snapshot.camera
        last = view.memo.get("logged_at_s", -math.inf)
        if cam is None or view.now - last < period:
            return []
        view.memo["logged_at_s"] = view.now
        seen = []
        for blob in cam.blobs:
            if colours and blob.colour not in colours:
                continue
            if overhead is not None:
                x, y = overhead.to_world(blob.x_px, blob.y_px, cam.width_px, cam.height_px)
            else:
                x, y = blob.x_px, blob.y_px
            seen.append({"colour": f"#{blob.colour:06x}", "x": round(x, 3), "y": round(y, 3)})
        return [("observation", {"objects": seen, "frame": "world" if overhead else "image"})]

    return TaskPlan(
        "monitor-object",
        (Stage("monitor", (Layer(Hold(), 0),)),),
        done=elapsed(duration),
        observe=observe,
        progress=_elapsed_progress(duration),
    )


# --- charging (used by the battery manager, not auctioned) -------------------------------------


def build_dock(p: Params, profile: RobotProfile) -> TaskPlan:
    x, y = number(p, "x"), number(p, "y")
    dock = DockAtCharger(x, y, tolerance_m=number(p, "tolerance_m"))
    # The pad itself is flat (rangers do not see it), so avoidance only steers around
    # whatever stands between the robot and the pad.
    layers = (*_avoid(profile, 0.3), Layer(dock, 1))
    return TaskPlan(
        "dock",
        (Stage("dock", layers, until=signal("docked", held_s=0.5)),),
        timeout_s=number(p, "timeout_s"),
        progress=_distance_progress(x, y),
    )


def build_undock(p: Params, profile: RobotProfile) -> TaskPlan:
    return TaskPlan(
        "undock",
        (Stage("back-off", (Layer(BackOff(duration_s=number(p, "duration_s"), turn_radps=0.0),
                                  1),), until=signal("backed-off")),),
    )


MOBILE_SONAR = frozenset({"mobile", "sonar"})

TASKS: dict[str, TaskSpec] = {
    spec.name: spec
    for spec in (
        TaskSpec(
            "goto-goal", MOBILE_SONAR,
            {"tolerance_m": 0.3, "speed_mps": 0.4, "safe_range_m": 0.5, "timeout_s": 300.0},
            ("x", "y"), build_goto,
            (WeightedMetric("distance", negative_distance(), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "drive to (x, y) avoiding obstacles with sonar", duration_param="timeout_s",
        ),
        _push_task("push-left-end", AIM_LEFT,
                   "push the left end of the box (as seen from behind it)"),
        _push_task("push-right-end", AIM_RIGHT, "push the right end of the box"),
        _push_task("push-box", AIM_MIDDLE, "push the box in the middle"),
        TaskSpec(
            "watch-box", frozenset({"mobile", "camera", "laser"}),
            {"lead_m": 1.0, "tolerance_rad": math.radians(8.0), "need_period_s": 4.0,
             "duration_s": 300.0, "laser_sector_rad": math.pi, "speed_mps": 0.15,
             "arrive_m": 0.4},
            ("colour", "goal_colour"), build_watch_box,
            (WeightedMetric("goal-visible", colour_visible("goal_colour"), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "lead the box to the goal and say which pushing task is needed",
        ),
        TaskSpec(
            "object-tracking", frozenset({"mobile", "camera"}),
            {"distance_m": 1.0, "duration_s": 60.0}, ("colour",), build_tracking,
            (WeightedMetric("visible", colour_visible(), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "find a colour and track it from a safe distance",
        ),
        TaskSpec(
            "sentry-duty", frozenset({"mobile", "camera", "laser"}),
            {"duration_s": 120.0, "approach_m": 1.0, "search_s": 120.0, "threshold_m": 0.15},
            ("colour",), build_sentry,
            (WeightedMetric("visible", colour_visible(), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "find a colour, turn about, raise an alarm on laser motion",
        ),
        TaskSpec(
            "cleanup", frozenset({"mobile", "camera", "bumper"}),
            {"duration_s": 300.0, "boxes": 1.0, "search_s": 60.0, "push_s": 60.0},
            ("colour",), build_cleanup,
            (WeightedMetric("visible", colour_visible(), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "push small boxes of a colour to the edge of the room",
        ),
        TaskSpec(
            "monitor-object", frozenset({OVERHEAD_CAMERA}),
            {"duration_s": 60.0, "period_s": 1.0, "colours": ""}, (), build_monitor,
            (WeightedMetric("available", constant(1.0), 1.0),),
            "log positions of coloured objects seen by the overhead camera",
            place=camera_place,
        ),
        TaskSpec(
            "watch-object-side", frozenset({"mobile", "camera"}),
            {"duration_s": 120.0, "tolerance_m": 0.3, "speed_mps": 0.4, "go_s": 240.0},
            ("colour", "x", "y"), build_watch_side,
            (WeightedMetric("distance", negative_distance(), 1.0),
             WeightedMetric("battery", battery_fraction, 0.5)),
            "one of two robots watching an object from two sides: go to a spot beside it, "
            "face it and hold",
        ),
    )
}

RESOURCES: frozenset[str] = frozenset().union(*(t.subjects for t in TASKS.values()))
"""Every resource some task needs (what a specialist has little of)."""

INTERNAL_TASKS: dict[str, TaskSpec] = {
    "dock": TaskSpec("dock", frozenset({"mobile"}), {"tolerance_m": 0.1, "timeout_s": 300.0},
                     ("x", "y"), build_dock, (), duration_param="timeout_s"),
    "undock": TaskSpec("undock", frozenset({"mobile"}), {"duration_s": 2.0}, (), build_undock,
                       ()),
}


def task_spec(name: str) -> TaskSpec:
    spec = TASKS.get(name) or INTERNAL_TASKS.get(name)
    if spec is None:
        raise ParamError(f"unknown task {name!r}; known: {', '.join(sorted(TASKS))}")
    return spec
