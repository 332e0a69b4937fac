"""Differential-drive helpers (pure): acceleration limits and odometry integration."""

from __future__ import annotations

import math


def ramp(current: float, target: float, max_step: float) -> float:
    """Move current towards target by at most max_step."""
    if target > current + max_step:
        return current + max_step
    if target < current - max_step:
        return current - max_step
    return target


def wrap_angle(a: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


def to_robot_frame(
    x0: float, y0: float, yaw0: float, x1: float, y1: float, yaw1: float
) -> tuple[float, float, float]:
    """The motion from pose 0 to pose 1 expressed in pose 0's frame: (forward, left, turn)."""
    dx, dy = x1 - x0, y1 - y0
    c, s = math.cos(yaw0), math.sin(yaw0)
    return c * dx + s * dy, -s * dx + c * dy, wrap_angle(yaw1 - yaw0)


def integrate(
    x: float, y: float, yaw: float, forward: float, left: float, turn: float
) -> tuple[float, float, float]:
    """Apply a robot-frame motion (forward, left, turn) to pose (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return x + c * forward - s * left, y + s * forward + c * left, wrap_angle(yaw + turn)


def yaw_of(q: tuple[float, float, float, float]) -> float:
    """The yaw of a quaternion (x, y, z, w)."""
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
