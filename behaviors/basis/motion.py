"""Small manoeuvres relative to the start of a task stage: hold still, turn about, back off."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.basis.speed_limits import ReversibleSpeedLimit
from behaviors.proposal import INACTIVE, Proposal, clamp
from behaviors.snapshot import Snapshot, wrap_angle


@dataclass(frozen=True, slots=True)
class Hold:
    """Stand still (always active)."""

    weight: float = 1.0
    name: str = "hold"
    max_speed_mps: float = 0.0
    max_turn_radps: float = 0.0

    def inputs_key(self, snapshot: Snapshot, now: float) -> int:
        """Always the same proposal (see `runner`)."""
        return 0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return Proposal(True, 0.0, 0.0, self.weight, "", 0.0)


@dataclass(frozen=True, slots=True)
class TurnAbout:
    """Turn in place by `angle_rad` relative to the heading at the stage start ("turned")."""

    angle_rad: float = math.pi
    tolerance_rad: float = math.radians(8.0)
    max_turn_radps: float = 0.8
    turn_gain: float = 1.5
    max_age_s: float = 0.5
    name: str = "turn-about"
    max_speed_mps: float = 0.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        odo = snapshot.odometry
        mark = snapshot.mark
        if odo is None or mark is None or mark.pose is None or now - odo.time_s > self.max_age_s:
            return INACTIVE
        target = mark.pose.yaw_rad + self.angle_rad
        error = wrap_angle(target - odo.pose.yaw_rad)
        if abs(error) <= self.tolerance_rad:
            return Proposal(True, 0.0, 0.0, 1.0, "turned", error)
        # Keep turning the same way for a half turn (the error flips sign near +-pi).
        if abs(error) > math.pi - self.tolerance_rad:
            error = math.copysign(abs(error), self.angle_rad)
        turn = clamp(self.turn_gain * error, self.max_turn_radps)
        if abs(turn) < 0.2 * self.max_turn_radps:
            turn = math.copysign(0.2 * self.max_turn_radps, turn)
        return Proposal(True, 0.0, turn, 1.0, "", error)


@dataclass(frozen=True, slots=True)
class BackOff(ReversibleSpeedLimit):
    """Reverse for `duration_s` after the stage start, turning a little ("backed-off")."""

    duration_s: float = 1.5
    speed_mps: float = 0.2
    turn_radps: float = 0.5
    name: str = "back-off"

    @property
    def max_turn_radps(self) -> float:
        return abs(self.turn_radps)

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        mark = snapshot.mark
        if mark is None or not math.isfinite(now):
            return INACTIVE
        if now - mark.time_s >= self.duration_s:
            return Proposal(True, 0.0, 0.0, 1.0, "backed-off", 0.0)
        return Proposal(True, -abs(self.speed_mps), self.turn_radps, 1.0, "", 0.0)


@dataclass(frozen=True, slots=True)
class Cruise(ReversibleSpeedLimit):
    """Drive straight ahead at `speed_mps` (always active; a low-priority default)."""

    speed_mps: float = 0.2
    weight: float = 0.5
    name: str = "cruise"
    max_turn_radps: float = 0.0

    def inputs_key(self, snapshot: Snapshot, now: float) -> int:
        """Always the same proposal (see `runner`)."""
        return 0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return Proposal(True, self.speed_mps, 0.0, self.weight, "", 0.0)


@dataclass(frozen=True, slots=True)
class CruiseOnHeading(ReversibleSpeedLimit):
    """Drive along `heading_rad` (odometry frame): turn towards it first, then go straight.

    A pusher uses it to push the box the way the watcher wants it to go, whatever angle it
    came in at. Forward only while within `tolerance_rad` of the heading.
    """

    heading_rad: float
    speed_mps: float = 0.2
    tolerance_rad: float = math.radians(25.0)
    max_turn_radps: float = 0.6
    turn_gain: float = 1.5
    max_age_s: float = 0.5
    weight: float = 0.5
    name: str = "cruise-on-heading"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        odo = snapshot.odometry
        if odo is None or now - odo.time_s > self.max_age_s or not math.isfinite(
            self.heading_rad
        ):
            return INACTIVE
        error = wrap_angle(self.heading_rad - odo.pose.yaw_rad)
        turn = clamp(self.turn_gain * error, self.max_turn_radps)
        if abs(error) > self.tolerance_rad:
            return Proposal(True, 0.0, turn, self.weight, "", error)
        return Proposal(True, self.speed_mps, turn, self.weight, "on-heading", error)
