"""Obstacle avoidance from a sonar ring or a laser scan."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import RangeScan, Snapshot

_HALF_PI = math.pi / 2.0


def _avoid(
    scan: RangeScan | None,
    now: float,
    *,
    safe_range_m: float,
    front_half_angle_rad: float,
    ignore_half_angle_rad: float,
    max_speed_mps: float,
    max_turn_radps: float,
    max_age_s: float,
) -> Proposal:
    if scan is None or not scan.ranges_m or now - scan.time_s > max_age_s:
        return INACTIVE
    # Sectors: a blind cone straight ahead (e.g. the box being pushed) is ignored.
    left = scan.min_in_sector(ignore_half_angle_rad, front_half_angle_rad)
    right = scan.min_in_sector(-front_half_angle_rad, -ignore_half_angle_rad)
    if ignore_half_angle_rad <= 0.0:
        front = min(left, right)
    else:
        front = math.inf
    nearest = min(left, right, front)
    if not nearest < safe_range_m:
        return INACTIVE
    urgency = min(1.0, max(0.0, (safe_range_m - nearest) / safe_range_m))
    # Turn towards the side with more room; ties turn left.
    side_left = scan.min_in_sector(0.0, _HALF_PI)
    side_right = scan.min_in_sector(-_HALF_PI, 0.0)
    direction = 1.0 if side_left >= side_right else -1.0
    turn = direction * max_turn_radps * (0.5 + 0.5 * urgency)
    if nearest < 0.5 * safe_range_m:
        speed = -0.25 * max_speed_mps  # too close: back away while turning
    else:
        speed = max_speed_mps * 0.3 * (1.0 - urgency)
    return Proposal(True, speed, turn, urgency, "obstacle", nearest)


@dataclass(frozen=True, slots=True)
class AvoidWithSonar:
    """Turn away from anything closer than `safe_range_m` in the front sonar sectors."""

    safe_range_m: float = 0.5
    front_half_angle_rad: float = math.radians(80.0)
    ignore_half_angle_rad: float = 0.0
    max_speed_mps: float = 0.3
    max_turn_radps: float = 1.0
    max_age_s: float = 0.5
    name: str = "avoid-obstacles-with-sonar"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return _avoid(
            snapshot.sonar,
            now,
            safe_range_m=self.safe_range_m,
            front_half_angle_rad=self.front_half_angle_rad,
            ignore_half_angle_rad=self.ignore_half_angle_rad,
            max_speed_mps=self.max_speed_mps,
            max_turn_radps=self.max_turn_radps,
            max_age_s=self.max_age_s,
        )


@dataclass(frozen=True, slots=True)
class AvoidWithLaser:
    """Turn away from anything closer than `safe_range_m` in the front laser sectors."""

    safe_range_m: float = 0.5
    front_half_angle_rad: float = math.radians(70.0)
    ignore_half_angle_rad: float = 0.0
    max_speed_mps: float = 0.3
    max_turn_radps: float = 1.0
    max_age_s: float = 0.5
    name: str = "avoid-obstacles-with-laser"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return _avoid(
            snapshot.laser,
            now,
            safe_range_m=self.safe_range_m,
            front_half_angle_rad=self.front_half_angle_rad,
            ignore_half_angle_rad=self.ignore_half_angle_rad,
            max_speed_mps=self.max_speed_mps,
            max_turn_radps=self.max_turn_radps,
            max_age_s=self.max_age_s,
        )
