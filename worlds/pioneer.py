"""Pioneer 2-DX device geometry used as defaults by the world loader.

Sonar ring poses are the 16 transducers of the Pioneer 2-DX front and rear arrays (metres and
degrees relative to the drive-axle centre, as in Player's p2os robot parameter table).
"""

from __future__ import annotations

import math

from worlds.spec import BodySpec, BumperSegment, Mount

SONAR_Z_M = 0.18
LASER_MOUNT = Mount(0.16, 0.0, 0.25, 0.0)
CAMERA_MOUNT = Mount(0.10, 0.0, 0.34, 0.0)
GRIPPER_MOUNT = Mount(0.28, 0.0, 0.05, 0.0)
FIDUCIAL_MOUNT = LASER_MOUNT

_SONAR_XY_DEG: tuple[tuple[float, float, float], ...] = (
    (0.069, 0.136, 90.0),
    (0.114, 0.119, 50.0),
    (0.148, 0.078, 30.0),
    (0.166, 0.027, 10.0),
    (0.166, -0.027, -10.0),
    (0.148, -0.078, -30.0),
    (0.114, -0.119, -50.0),
    (0.069, -0.136, -90.0),
    (-0.157, -0.136, -90.0),
    (-0.203, -0.119, -130.0),
    (-0.237, -0.078, -150.0),
    (-0.255, -0.027, -170.0),
    (-0.255, 0.027, 170.0),
    (-0.237, 0.078, 150.0),
    (-0.203, 0.119, 130.0),
    (-0.157, 0.136, 90.0),
)


def sonar_ring() -> tuple[Mount, ...]:
    """The 16 Pioneer 2-DX transducer poses (x, y, z, yaw_rad)."""
    return tuple(Mount(x, y, SONAR_Z_M, math.radians(a)) for x, y, a in _SONAR_XY_DEG)


def bumper_ring(body: BodySpec, per_side: int = 5) -> tuple[BumperSegment, ...]:
    """Front then rear bumper panels on an arc around the body centre.

    Each side spans 130 degrees split into ``per_side`` panels; a panel's yaw is its outward
    normal, its (x, y) the panel midpoint.
    """
    radius = body.length_m / 2.0 + 0.005
    span = math.radians(130.0)
    step = span / per_side
    segments: list[BumperSegment] = []
    for centre in (0.0, math.pi):
        for i in range(per_side):
            a = centre - span / 2.0 + step * (i + 0.5)
            segments.append(
                BumperSegment(
                    x=body.offset_x_m + radius * math.cos(a),
                    y=radius * math.sin(a),
                    yaw=math.atan2(math.sin(a), math.cos(a)),
                    length_m=radius * step,
                    radius_m=radius,
                )
            )
    return tuple(segments)
