"""Going places: servo-to-location (goto) and wander."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from behaviors.basis.speed_limits import ForwardSpeedLimit
from behaviors.proposal import INACTIVE, Proposal, clamp
from behaviors.snapshot import Snapshot, wrap_angle

_MASK32 = 0xFFFFFFFF


@dataclass(frozen=True, slots=True)
class ServoToLocation:
    """Drive to a point in the odometry frame; stop within `tolerance_m` (signal "at-goal")."""

    goal_x_m: float
    goal_y_m: float
    tolerance_m: float = 0.25
    max_speed_mps: float = 0.4
    max_turn_radps: float = 1.0
    turn_gain: float = 2.0
    slow_radius_m: float = 0.6
    turn_in_place_rad: float = math.radians(60.0)
    max_age_s: float = 0.5
    weight: float = 0.6
    name: str = "servo-to-location"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return drive_to_point(self, snapshot, now, self.goal_x_m, self.goal_y_m, self.weight,
                              "at-goal", self.turn_in_place_rad)


class PointApproach(Protocol):
    """The settings `drive_to_point` reads from the behaviour that drives."""

    @property
    def tolerance_m(self) -> float: ...
    @property
    def max_speed_mps(self) -> float: ...
    @property
    def max_turn_radps(self) -> float: ...
    @property
    def turn_gain(self) -> float: ...
    @property
    def slow_radius_m(self) -> float: ...
    @property
    def max_age_s(self) -> float: ...


def drive_to_point(
    settings: PointApproach, snapshot: Snapshot, now: float, x_m: float, y_m: float,
    weight: float, arrived: str, turn_in_place_rad: float, min_slow_fraction: float | None = None,
) -> Proposal:
    """Drive to (`x_m`, `y_m`) in the odometry frame: signal `arrived` within `tolerance_m`.

    Turns towards the point, in place while it is more than `turn_in_place_rad` off, and
    slows down within `slow_radius_m` (to no less than `min_slow_fraction` of full speed when
    given). Inactive without fresh odometry or with a non-finite distance.
    """
    odo = snapshot.odometry
    if odo is None or now - odo.time_s > settings.max_age_s:
        return INACTIVE
    pose = odo.pose
    distance = pose.distance_to(x_m, y_m)
    if not math.isfinite(distance):
        return INACTIVE
    if distance <= settings.tolerance_m:
        return Proposal(True, 0.0, 0.0, weight, arrived, distance)
    bearing = pose.bearing_to(x_m, y_m)
    turn = clamp(settings.turn_gain * bearing, settings.max_turn_radps)
    if abs(bearing) > turn_in_place_rad:
        speed = 0.0
    else:
        slow = distance / settings.slow_radius_m
        if min_slow_fraction is not None:
            slow = max(min_slow_fraction, slow)
        speed = settings.max_speed_mps * math.cos(bearing) * min(1.0, slow)
    return Proposal(True, speed, turn, weight, "", distance)


def _mix(seed: int, bucket: int) -> int:
    """A small integer hash (deterministic, no RNG state)."""
    h = (seed * 0x9E3779B1 + bucket * 0x85EBCA6B + 0x632BE5AB) & _MASK32
    h ^= h >> 15
    h = (h * 0x2C1B3C6D) & _MASK32
    h ^= h >> 12
    h = (h * 0x297A2D39) & _MASK32
    h ^= h >> 15
    return h


@dataclass(frozen=True, slots=True)
class Wander(ForwardSpeedLimit):
    """Drive forward, changing the turn rate every `period_s` to a value drawn from `seed`.

    Pure: the turn rate is a hash of (seed, time bucket), so it repeats for the same time.
    A `turn_bias_radps` makes it a search: it keeps turning one way, at a varying rate.
    """

    seed: int = 0
    speed_mps: float = 0.25
    max_turn_radps: float = 0.6
    turn_bias_radps: float = 0.0
    period_s: float = 2.0
    straight_fraction: float = 0.4
    weight: float = 0.2
    name: str = "wander"

    def inputs_key(self, snapshot: Snapshot, now: float) -> int | None:
        """The time bucket: the proposal changes only when it does (see `runner`)."""
        if not math.isfinite(now):
            return None
        return int(now // self.period_s) if self.period_s > 0 else 0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        bucket = self.inputs_key(snapshot, now)
        if bucket is None:
            return INACTIVE
        h = _mix(self.seed, bucket)
        u = (h & 0xFFFF) / 65535.0
        bias = clamp(self.turn_bias_radps, self.max_turn_radps)
        if u < self.straight_fraction:
            turn = bias
        else:
            v = ((h >> 16) & 0xFFFF) / 65535.0
            turn = bias + (2.0 * v - 1.0) * (self.max_turn_radps - abs(bias))
        return Proposal(True, self.speed_mps, clamp(turn, self.max_turn_radps), self.weight, "",
                        0.0)


def heading_error(target_rad: float, yaw_rad: float) -> float:
    return wrap_angle(target_rad - yaw_rad)
