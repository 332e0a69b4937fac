"""Structs shared by several interfaces (``player.h``): poses, boxes, device addresses."""

from __future__ import annotations

from player_server.protocol.xdr import F64, U16, U32, xdr_dataclass


@xdr_dataclass
class Pose2d:
    """px, py [m], pa [rad]."""

    px: F64 = 0.0
    py: F64 = 0.0
    pa: F64 = 0.0


@xdr_dataclass
class Pose3d:
    """px, py, pz [m], proll, ppitch, pyaw [rad]."""

    px: F64 = 0.0
    py: F64 = 0.0
    pz: F64 = 0.0
    proll: F64 = 0.0
    ppitch: F64 = 0.0
    pyaw: F64 = 0.0


@xdr_dataclass
class Bbox3d:
    """sw (width), sl (length), sh (height) [m]."""

    sw: F64 = 0.0
    sl: F64 = 0.0
    sh: F64 = 0.0


@xdr_dataclass
class Bbox2d:
    """sw (width), sl (length) [m]."""

    sw: F64 = 0.0
    sl: F64 = 0.0


@xdr_dataclass
class DevAddr:
    """Device address ``host:robot:interf:index`` (12 bytes in C, 16 on the wire)."""

    host: U32 = 0
    robot: U32 = 0
    interf: U16 = 0
    index: U16 = 0


POSE2D_ZERO = Pose2d()
POSE3D_ZERO = Pose3d()
BBOX3D_ZERO = Bbox3d()
BBOX2D_ZERO = Bbox2d()
DEVADDR_ZERO = DevAddr()


@xdr_dataclass
class Geom3d:
    """``pose pose3d, size bbox3d`` (72 B): position2d, laser and ptz geometry."""

    pose: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO


POSE2D_ZERO = POSE2D_ZERO
POSE3D_ZERO = POSE3D_ZERO
BBOX3D_ZERO = BBOX3D_ZERO
BBOX2D_ZERO = BBOX2D_ZERO
DEVADDR_ZERO = DEVADDR_ZERO
