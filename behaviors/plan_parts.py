"""Pieces that many task plans share: obstacle avoidance with the robot's best ranger, a
search that keeps turning, and progress by time or by distance to a place."""

from __future__ import annotations

from collections.abc import Callable

from behaviors.arbiter import Layer
from behaviors.basis import AvoidWithLaser, AvoidWithSonar, Wander
from behaviors.profile import RobotProfile
from behaviors.task import TickView


def avoid_layers(profile: RobotProfile, safe_range_m: float,
                 ignore_half_angle_rad: float = 0.0,
                 prefer_laser: bool = False) -> tuple[Layer, ...]:
    """Keep `safe_range_m` from obstacles with the laser (when preferred, or without sonar)
    or the sonar ring; nothing for a robot with neither."""
    if profile.has("laser") and (prefer_laser or not profile.has("sonar")):
        return (Layer(AvoidWithLaser(safe_range_m=safe_range_m,
                                     ignore_half_angle_rad=ignore_half_angle_rad), 2),)
    if profile.has("sonar"):
        return (Layer(AvoidWithSonar(safe_range_m=safe_range_m,
                                     ignore_half_angle_rad=ignore_half_angle_rad), 2),)
    return ()


def search(profile: RobotProfile, speed_mps: float = 0.0) -> Wander:
    """Look for something: keep turning (left or right, by seed) at a varying rate."""
    bias = 0.4 if profile.seed % 2 == 0 else -0.4
    return Wander(seed=profile.seed, speed_mps=speed_mps, max_turn_radps=0.6,
                  turn_bias_radps=bias, straight_fraction=0.0)


def elapsed_progress(duration_s: float) -> Callable[[TickView], float]:
    return lambda view: view.task_elapsed_s / duration_s if duration_s > 0 else 0.0


def distance_progress(x: float, y: float) -> Callable[[TickView], float]:
    def progress(view: TickView) -> float:
        pose = view.snapshot.pose
        if pose is None:
            return 0.0
        d = pose.distance_to(x, y)
        start = view.memo.setdefault("start_distance_m", d)
        return 1.0 - d / start if start > 0 else 1.0

    return progress
