"""Docking at a charging station."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.basis.navigate import drive_to_point
from behaviors.proposal import Proposal
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
        return drive_to_point(self, snapshot, now, self.charger_x_m, self.charger_y_m, 1.0,
                              "at-charger", math.radians(50.0), min_slow_fraction=0.15)
