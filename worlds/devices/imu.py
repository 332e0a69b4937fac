"""An inertial measurement unit: the heading, turn rates and accelerations of the robot body.

``[robots.imu]`` puts the unit at `pose` on the robot (forward, left, up from the drive-axle
centre, and its yaw). It measures the motion of that point: accelerations in its own frame
(with gravity's reaction, +9.81 m/s^2, on z), turn rates, and a heading that starts as the
world's yaw and is zeroed by a reset, drifting away from the truth at `yaw_drift` from there.
Each measure has seeded Gaussian noise of its standard deviation (0: none). The simulator's
`player_server.sim.devices.imu` measures it; Player serves it as ``imu:0``
(`player_server.drivers.imu`), sending the DATA `datatype` names until a client asks for
another: 1 pose, 2 calibrated values, 3 quaternion, 4 Euler angles, 5 full state.
"""

from __future__ import annotations

from dataclasses import dataclass

from worlds.device_kinds import declare_device
from worlds.params import param
from worlds.spec import Mount

IMU_MOUNT = Mount(0.0, 0.0, 0.2, 0.0)
"""On the body's axis above the drive axle, 0.2 m up."""


@declare_device("imu", doc="an inertial measurement unit: heading, turn rates, accelerations",
                draw_w=0.1)
@dataclass(frozen=True)
class ImuSpec:
    """An XSens-like unit sending Euler angles with its calibrated values by default."""

    pose: Mount = param(IMU_MOUNT, "where it sits: [x, y, z, yaw_deg] on the robot",
                        kind="mount")
    datatype: int = param(4, "the DATA sent until a client asks for another (1 pose, "
                             "2 calibrated, 3 quaternion, 4 Euler, 5 full state)", min=1, max=5)
    yaw_noise_rad: float = param(0.0, "standard deviation of the heading", kind="angle",
                                 min=0.0)
    yaw_drift_radps: float = param(0.0, "how fast the heading drifts from the truth "
                                        "after a reset (rad/s)")
    gyro_noise_radps: float = param(0.0, "standard deviation of the turn rates (rad/s)",
                                    min=0.0)
    accel_noise_mps2: float = param(0.0, "standard deviation of the accelerations (m/s^2)",
                                    min=0.0)
