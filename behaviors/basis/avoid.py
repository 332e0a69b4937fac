"""Obstacle avoidance from a sonar ring or a laser scan."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import Snapshot

_HALF_PI = math.pi / 2.0


# the range devices an avoid behaviour can read, and how wide a front it watches on each
RANGE_DEVICES: dict[str, float] = {"sonar": math.radians(80.0), "laser": math.radians(70.0)}


@dataclass(frozen=True, slots=True)
class Avoid:
    """Turn away from anything closer than `safe_range_m` in the front sectors of one range
    device (`device`: "sonar" or "laser"); the front is the device's own width unless given."""

    device: str
    safe_range_m: float = 0.5
    front_half_angle_rad: float | None = None
    ignore_half_angle_rad: float = 0.0
    max_speed_mps: float = 0.3
    max_turn_radps: float = 1.0
    max_age_s: float = 0.5
    name: str = ""

    def __post_init__(self) -> None:
        if self.device not in RANGE_DEVICES:
            raise ValueError(f"avoid: device must be one of {sorted(RANGE_DEVICES)}, "
                             f"found {self.device!r}")
        if self.front_half_angle_rad is None:
            object.__setattr__(self, "front_half_angle_rad", RANGE_DEVICES[self.device])
        if not self.name:
            object.__setattr__(self, "name", f"avoid-obstacles-with-{self.device}")

    def _nearest(self, snapshot: Snapshot, now: float) -> tuple[Any, float]:
        """(the scan, the nearest range in the front sectors); inf when there is no fresh
        scan."""
        scan = snapshot.sonar if self.device == "sonar" else snapshot.laser
        front_half = self.front_half_angle_rad
        assert front_half is not None  # set in __post_init__
        if scan is None or not scan.ranges_m or now - scan.time_s > self.max_age_s:
            return scan, math.inf
        # Sectors: a blind cone straight ahead (e.g. the box being pushed) is ignored.
        ignore_half = self.ignore_half_angle_rad
        left = scan.min_in_sector(ignore_half, front_half)
        right = scan.min_in_sector(-front_half, -ignore_half)
        return scan, min(left, right)

    def inputs_key(self, snapshot: Snapshot, now: float) -> bool | None:
        """False while nothing is closer than `safe_range_m` ahead (or there is no fresh
        scan): the proposal is then INACTIVE whatever the ranges (see `runner`); None:
        decide."""
        return False if not self._nearest(snapshot, now)[1] < self.safe_range_m else None

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        scan, nearest = self._nearest(snapshot, now)
        safe = self.safe_range_m
        if not nearest < safe:
            return INACTIVE
        urgency = min(1.0, max(0.0, (safe - nearest) / safe))
        # Turn towards the side with more room; ties turn left.
        side_left = scan.min_in_sector(0.0, _HALF_PI)
        side_right = scan.min_in_sector(-_HALF_PI, 0.0)
        direction = 1.0 if side_left >= side_right else -1.0
        turn = direction * self.max_turn_radps * (0.5 + 0.5 * urgency)
        if nearest < 0.5 * safe:
            speed = -0.25 * self.max_speed_mps  # too close: back away while turning
        else:
            speed = self.max_speed_mps * 0.3 * (1.0 - urgency)
        return Proposal(True, speed, turn, urgency, "obstacle", nearest)


def AvoidWithSonar(**options: Any) -> Avoid:
    """`Avoid` reading the sonar ring."""
    return Avoid("sonar", **options)


def AvoidWithLaser(**options: Any) -> Avoid:
    """`Avoid` reading the laser scan."""
    return Avoid("laser", **options)
