"""Watching for motion with the laser."""

from __future__ import annotations

from dataclasses import dataclass

from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import Snapshot


@dataclass(frozen=True, slots=True)
class WatchForMotionWithLaser:
    """Hold still and compare the laser scan with the one taken at the stage start.

    Signals "motion" (value = number of changed readings) when at least `min_readings`
    readings differ from the reference by more than `threshold_m`.
    """

    threshold_m: float = 0.15
    min_readings: int = 3
    max_age_s: float = 0.5
    name: str = "watch-for-motion-with-laser"
    max_speed_mps: float = 0.0
    max_turn_radps: float = 0.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        laser = snapshot.laser
        mark = snapshot.mark
        if laser is None or now - laser.time_s > self.max_age_s:
            return INACTIVE
        reference = None if mark is None else mark.laser
        if reference is None or len(reference.ranges_m) != len(laser.ranges_m):
            return Proposal(True, 0.0, 0.0, 1.0, "", 0.0)
        threshold = self.threshold_m
        changed = 0
        for now_r, ref_r in zip(laser.ranges_m, reference.ranges_m, strict=True):
            if abs(now_r - ref_r) > threshold:
                changed += 1
        if changed >= self.min_readings:
            return Proposal(True, 0.0, 0.0, 1.0, "motion", float(changed))
        return Proposal(True, 0.0, 0.0, 1.0, "", float(changed))
