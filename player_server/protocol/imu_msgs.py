"""Bodies of the imu interface (Player's ``060_imu.def``): an inertial measurement unit.

DATA subtypes 1-5 are the five layouts a unit may send (one at a time, chosen with REQ 1
SET_DATATYPE, whose value is the DATA subtype); REQ 2 RESET_ORIENTATION zeroes the heading.
Both requests are answered with an empty ACK.
"""

from __future__ import annotations

from player_server.protocol.common import POSE3D_ZERO, Pose3d
from player_server.protocol.xdr import F32, F64, U8, U32, xdr_dataclass


@xdr_dataclass
class ImuDataState:
    """imu DATA 1 STATE: the unit's pose."""

    pose: Pose3d = POSE3D_ZERO


@xdr_dataclass
class ImuDataCalib:
    """imu DATA 2 CALIB: calibrated accelerations [m/s^2], turn rates [rad/s] and magnetic
    field, along the unit's x, y, z."""

    accel_x: F32 = 0.0
    accel_y: F32 = 0.0
    accel_z: F32 = 0.0
    gyro_x: F32 = 0.0
    gyro_y: F32 = 0.0
    gyro_z: F32 = 0.0
    magn_x: F32 = 0.0
    magn_y: F32 = 0.0
    magn_z: F32 = 0.0


IMU_CALIB_ZERO = ImuDataCalib()


@xdr_dataclass
class ImuDataQuat:
    """imu DATA 3 QUAT: calibrated values and the orientation as a quaternion (q0 scalar)."""

    calib_data: ImuDataCalib = IMU_CALIB_ZERO
    q0: F32 = 1.0
    q1: F32 = 0.0
    q2: F32 = 0.0
    q3: F32 = 0.0


@xdr_dataclass
class Orientation3d:
    """``player_orientation_3d_t``: proll, ppitch, pyaw [rad]."""

    proll: F64 = 0.0
    ppitch: F64 = 0.0
    pyaw: F64 = 0.0


@xdr_dataclass
class ImuDataEuler:
    """imu DATA 4 EULER: calibrated values and the orientation as Euler angles."""

    calib_data: ImuDataCalib = IMU_CALIB_ZERO
    orientation: Orientation3d = Orientation3d()


@xdr_dataclass
class ImuDataFullstate:
    """imu DATA 5 FULLSTATE: pose, velocity (m/s and rad/s) and acceleration."""

    pose: Pose3d = POSE3D_ZERO
    vel: Pose3d = POSE3D_ZERO
    acc: Pose3d = POSE3D_ZERO


@xdr_dataclass
class ImuDatatypeConfig:
    """imu REQ 1 SET_DATATYPE: the DATA subtype to send from now on (1-5)."""

    value: U8 = 0


@xdr_dataclass
class ImuResetOrientationConfig:
    """imu REQ 2 RESET_ORIENTATION (value: driver-specific)."""

    value: U32 = 0
