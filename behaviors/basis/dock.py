"""Docking at a charging station."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.proposal import INACTIVE, Proposal, clamp
from behaviors.snapshot import Snapshot


@dataclass(frozen=True, slots=True)
class DockAtCharger:
    """Drive onto the charger at (`charger_x_m`, `charger_y_m`) and stop once charging.

    Signals "docked" as soon as the power device reports that it is receiving charge, and
    "at-charger" when it stands on the charger without charge flowing (yet).
    """

    charger_x_m: float
    charger_y_m: float
    tolerance_m: float = 0.1
    max_speed_mps: float = 0.35
    max_turn_radps: float = 1.0
    turn_gain: float = 2.0
    slow_radius_m: float = 0.8
    max_age_s: float = 0.5
    name: str = "dock-at-charger"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        power = snapshot.power
        if power is not None and now - power.time_s <= self.max_age_s and power.charging > 0:
            return Proposal(True, 0.0, 0.0, 1.0, "docked", power.percent)
        odo = snapshot.odometry
        if odo is None or now - odo.time_s > self.max_age_s:
            return INACTIVE
        pose = odo.pose
        distance = pose.distance_to(self.charger_x_m, self.charger_y_m)
        if not math.isfinite(distance):
            return INACTIVE
        if distance <= self.tolerance_m:
            return Proposal(True, 0.0, 0.0, 1.0, "at-charger", distance)
        bearing = pose.bearing_to(self.charger_x_m, self.charger_y_m)
        turn = clamp(self.turn_gain * bearing, self.max_turn_radps)
        if abs(bearing) > math.radians(50.0):
            speed = 0.0
        else:
            speed = self.max_speed_mps * math.cos(bearing) * min(
                1.0, max(0.15, distance / self.slow_radius_m)
            )
        return Proposal(True, speed, turn, 1.0, "", distance)
