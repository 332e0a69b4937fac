"""Bodies of the actuated interfaces: power (2), gripper (3), position2d (4), ptz (8)."""

from __future__ import annotations

from player_server.protocol.common import (
    BBOX3D_ZERO,
    POSE2D_ZERO,
    POSE3D_ZERO,
    Bbox3d,
    Pose2d,
    Pose3d,
)
from player_server.protocol.xdr import F32, F64, I32, U8, U32, U32Array, xdr_dataclass


@xdr_dataclass
class PowerData:
    """power DATA 1 STATE; ``valid`` says which fields are meaningful."""

    valid: U32 = 0
    volts: F32 = 0.0
    percent: F32 = 0.0
    joules: F32 = 0.0
    watts: F32 = 0.0
    charging: I32 = 0


@xdr_dataclass
class PowerChargePolicyConfig:
    """power REQ 1 SET_CHARGING_POLICY."""

    enable_input: U8 = 1
    enable_output: U8 = 1


@xdr_dataclass
class GripperData:
    """gripper DATA 1 STATE: state (OPEN 1, CLOSED 2, MOVING 3, ERROR 4), beams, stored."""

    state: U8 = 0
    beams: U32 = 0
    stored: U8 = 0


@xdr_dataclass
class GripperGeom:
    """gripper REQ 1 GET_GEOM reply."""

    pose: Pose3d = POSE3D_ZERO
    outer_size: Bbox3d = BBOX3D_ZERO
    inner_size: Bbox3d = BBOX3D_ZERO
    num_beams: U8 = 0
    capacity: U8 = 0


@xdr_dataclass
class Position2dData:
    """position2d DATA 1 STATE: odometric pose, velocity, stall."""

    pos: Pose2d = POSE2D_ZERO
    vel: Pose2d = POSE2D_ZERO
    stall: U8 = 0


@xdr_dataclass
class Position2dGeom:
    """position2d GET_GEOM reply and DATA 2 GEOM."""

    pose: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO


@xdr_dataclass
class Position2dCmdVel:
    """position2d CMD 1 VEL: vx, vy, vyaw and motor state."""

    vel: Pose2d = POSE2D_ZERO
    state: U8 = 1


@xdr_dataclass
class Position2dCmdPos:
    """position2d CMD 2 POS: target pose (odometric frame), speeds, motor state."""

    pos: Pose2d = POSE2D_ZERO
    vel: Pose2d = POSE2D_ZERO
    state: U8 = 1


@xdr_dataclass
class Position2dCmdCar:
    """position2d CMD 3 CAR: forward velocity and relative steering angle."""

    velocity: F64 = 0.0
    angle: F64 = 0.0


@xdr_dataclass
class Position2dCmdVelHead:
    """position2d CMD 4 VEL_HEAD: forward velocity and absolute heading."""

    velocity: F64 = 0.0
    angle: F64 = 0.0


@xdr_dataclass
class Position2dPowerConfig:
    """position2d REQ 2 MOTOR_POWER."""

    state: U8 = 0


@xdr_dataclass
class Position2dVelocityModeConfig:
    """position2d REQ 3 VELOCITY_MODE."""

    value: U32 = 0


@xdr_dataclass
class Position2dPositionModeReq:
    """position2d REQ 4 POSITION_MODE (0 velocity, 1 position)."""

    state: U32 = 0


@xdr_dataclass
class Position2dSetOdomReq:
    """position2d REQ 5 SET_ODOM."""

    pose: Pose2d = POSE2D_ZERO


@xdr_dataclass
class Position2dPidReq:
    """position2d REQ 7 SPEED_PID / REQ 8 POSITION_PID."""

    kp: F32 = 0.0
    ki: F32 = 0.0
    kd: F32 = 0.0


@xdr_dataclass
class Position2dSpeedProfReq:
    """position2d REQ 9 SPEED_PROF."""

    speed: F32 = 0.0
    acc: F32 = 0.0


@xdr_dataclass
class PtzData:
    """ptz DATA 1 STATE (rad, rad, field of view rad, rad/s, rad/s, status)."""

    pan: F32 = 0.0
    tilt: F32 = 0.0
    zoom: F32 = 0.0
    panspeed: F32 = 0.0
    tiltspeed: F32 = 0.0
    status: U32 = 0


@xdr_dataclass
class PtzCmd:
    """ptz CMD 1 STATE: absolute targets and speeds."""

    pan: F32 = 0.0
    tilt: F32 = 0.0
    zoom: F32 = 0.0
    panspeed: F32 = 0.0
    tiltspeed: F32 = 0.0


@xdr_dataclass
class PtzReqGeneric:
    """ptz REQ 1 GENERIC."""

    config: U32Array = ()


@xdr_dataclass
class PtzReqControlMode:
    """ptz REQ 2 CONTROL_MODE (VELOCITY 0, POSITION 1)."""

    mode: U32 = 1


@xdr_dataclass
class PtzGeom:
    """ptz REQ 4 GEOM reply."""

    pos: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO


@xdr_dataclass
class PtzReqStatus:
    """ptz REQ 5 STATUS reply."""

    status: U32 = 0
