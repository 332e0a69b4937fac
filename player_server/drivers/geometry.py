"""Conversions from world-spec geometry to Player geometry structs."""

from __future__ import annotations

import math
from typing import Any

from player_server.protocol.common import Bbox3d, Pose3d


def mount_pose(mount: Any, pitch_rad: float = 0.0) -> Pose3d:
    """A sensor mount (x, y, z, yaw) as a Player pose3d in the robot frame."""
    return Pose3d(float(mount.x), float(mount.y), float(mount.z), 0.0, pitch_rad,
                  float(mount.yaw))


def body_geometry(robot: Any) -> tuple[Pose3d, Bbox3d]:
    """Robot body pose (centre of the box relative to the origin) and size (w, l, h)."""
    body = robot.body
    pose = Pose3d(float(body.offset_x_m), 0.0, float(body.height_m) / 2.0, 0.0, 0.0, 0.0)
    return pose, Bbox3d(float(body.width_m), float(body.length_m), float(body.height_m))


def wrap_angle(a: float) -> float:
    """Angle in (-pi, pi]."""
    a = math.fmod(a + math.pi, 2.0 * math.pi)
    if a <= 0.0:
        a += 2.0 * math.pi
    return a - math.pi


def finite(*values: float) -> None:
    """Raise ValueError unless every value is a finite number."""
    for v in values:
        if not math.isfinite(v):
            raise ValueError(f"expected finite numbers, got {values}")
