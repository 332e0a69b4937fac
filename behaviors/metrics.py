"""Metric functions: a robot's fitness for a task instance, higher is better.

A metric looks at the robot's own latest snapshot (and the task's parameters) and returns a
score, or None when it cannot be evaluated (e.g. the colour is not in view). A task combines
its metrics as a weighted sum; if any weighted metric is None the robot cannot bid.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from behaviors.basis.colour import end_px
from behaviors.params import colour_of
from behaviors.profile import RobotProfile
from behaviors.snapshot import Snapshot

Params = Mapping[str, object]
MetricFn = Callable[[Snapshot, Params, RobotProfile], float | None]


@dataclass(frozen=True, slots=True)
class WeightedMetric:
    name: str
    fn: MetricFn
    weight: float = 1.0


def weighted_sum(
    metrics: Sequence[WeightedMetric], snapshot: Snapshot, params: Params, profile: RobotProfile
) -> float | None:
    total = 0.0
    for m in metrics:
        value = m.fn(snapshot, params, profile)
        if value is None or not math.isfinite(value):
            return None
        total += m.weight * value
    return total


def negative_distance(x_key: str = "x", y_key: str = "y") -> MetricFn:
    """-(straight-line distance in metres) from the robot to the point (params[x], params[y])."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        pose = snapshot.pose
        if pose is None:
            return None
        return -pose.distance_to(float(params[x_key]), float(params[y_key]))  # type: ignore[arg-type]

    return metric


def colour_alignment(aim_fraction: float, colour_key: str = "colour") -> MetricFn:
    """-(|bearing| in radians) of the blob's end to push (its centre for 0.5).

    This is the pusher's "how well placed am I, as seen from my camera": 0 when that end is
    straight ahead; an end outside the image scores worse than any end in view.
    """

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        view = snapshot.camera
        if view is None:
            return None
        blob = view.largest(colour_of(params[colour_key]))
        if blob is None:
            return None
        px = end_px(blob, aim_fraction, view.width_px)
        if px is None:
            return -(view.fov_rad / 2.0 + abs(aim_fraction - 0.5))
        return -abs(view.bearing_of_px(px))

    return metric


def colour_proximity(colour_key: str = "colour") -> MetricFn:
    """-(range in metres) to the largest blob of the colour (None when not seen)."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        view = snapshot.camera
        if view is None:
            return None
        blob = view.largest(colour_of(params[colour_key]))
        if blob is None or not math.isfinite(blob.range_m):
            return None
        return -blob.range_m

    return metric


def colour_visible(colour_key: str = "colour") -> MetricFn:
    """1 when the colour is in view, 0 when not (never None if there is a camera)."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        view = snapshot.camera
        if view is None:
            return None
        return 1.0 if view.largest(colour_of(params[colour_key])) is not None else 0.0

    return metric


def battery_fraction(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
    """Remaining charge in [0, 1] (0.5 when the robot has no power device)."""
    power = snapshot.power
    if power is None:
        return 0.5
    return max(0.0, min(1.0, power.percent / 100.0))


def constant(value: float) -> MetricFn:
    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        return value

    return metric


def place_distance(colour_key: str = "colour") -> MetricFn:
    """-(metres) from the robot to where the task takes it: the task's (x, y) if it names
    one, else the nearest coloured object or box of the task's colour where the world file
    puts it (the robot's map; boxes pushed away since are not followed). 0 when the robot
    has no pose or the task no place: the term then does not tell robots apart."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        pose = snapshot.pose
        if pose is None:
            return 0.0
        if "x" in params and "y" in params:
            return -pose.distance_to(float(params["x"]), float(params["y"]))  # type: ignore[arg-type]
        if colour_key not in params:
            return 0.0
        colour = colour_of(params[colour_key])
        ranges = [pose.distance_to(x, y) for c, x, y in profile.landmarks if c == colour]
        return -min(ranges) if ranges else 0.0

    return metric


def spare_resources(needed: frozenset[str], resources: frozenset[str]) -> MetricFn:
    """-(number of the robot's `resources` the task does not need): a specialist, with
    nothing to spare, scores higher than a generalist, who stays free for later tasks."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        return -float(len((profile.subjects & resources) - needed))

    return metric


def unseen_fallback(inner: MetricFn, unseen: float) -> MetricFn:
    """A camera metric that scores `unseen` (instead of not bidding) when the colour is out
    of view: a pusher that lost sight of the box can still find it, only worse placed."""

    def metric(snapshot: Snapshot, params: Params, profile: RobotProfile) -> float | None:
        if snapshot.camera is None:
            return None
        value = inner(snapshot, params, profile)
        return unseen if value is None else value

    return metric
