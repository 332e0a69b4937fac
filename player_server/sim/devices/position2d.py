"""Position2d: the differential drive's commands and the odometry it reports.

The world moves the bodies (it steps the physics with the drive's velocities); this model
takes the commands (velocity, motor power) and keeps each robot's odometry, with the noise
of its world-file entry, and its stall flag.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from player_server.sim.devices.base import StatelessModel
from player_server.sim.drive import wrap_angle
from player_server.sim.readings import Odometry, fast_constructor

_make_odometry = fast_constructor(Odometry)

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState


class Position2dModel(StatelessModel):
    """Odometry advances with the bodies' poses (`advance_odometry`), not in `advance`."""

    kinds: ClassVar[tuple[str, ...]] = ("position2d",)
    order: ClassVar[int] = 10

    def advance_odometry(self, st: RobotState, x: float, y: float, yaw: float, dt: float) -> None:
        """Odometry (with its noise), its velocity and the stall flag from the robot's true
        motion over the tick that ended at (x, y, yaw)."""
        self.advance_all([(st, x, y, yaw)], dt)

    def advance_all(self, moves: list[tuple[RobotState, float, float, float]], dt: float) -> None:
        """`advance_odometry` for each (robot, x, y, yaw), in order (`drive.to_robot_frame`
        and `drive.integrate` written out: this runs for every robot every tick)."""
        cos, sin, atan2, hypot = math.cos, math.sin, math.atan2, math.hypot
        for st, x, y, yaw in moves:
            # to_robot_frame(st.x, st.y, st.yaw, x, y, yaw)
            dx, dy = x - st.x, y - st.y
            c, s = cos(st.yaw), sin(st.yaw)
            d_yaw = yaw - st.yaw
            fwd, left, turn = c * dx + s * dy, -s * dx + c * dy, atan2(sin(d_yaw), cos(d_yaw))
            p2d = st.spec.devices.position2d
            if p2d is not None and (p2d.odom_noise_fraction > 0
                                    or p2d.odom_yaw_noise_fraction > 0):
                n = st.rng.standard_normal(2)
                fwd *= 1.0 + p2d.odom_noise_fraction * float(n[0])
                left *= 1.0 + p2d.odom_noise_fraction * float(n[0])
                turn *= 1.0 + p2d.odom_yaw_noise_fraction * float(n[1])
            # integrate(*st.odom, fwd, left, turn)
            ox, oy, oyaw = st.odom
            c, s = cos(oyaw), sin(oyaw)
            o_yaw = oyaw + turn
            st.odom = (ox + c * fwd - s * left, oy + s * fwd + c * left,
                       atan2(sin(o_yaw), cos(o_yaw)))
            st.odom_v = (fwd / dt, left / dt, turn / dt)
            commanded = abs(st.v) * dt
            st.stall = commanded > 0.01 * dt and hypot(fwd, left) < 0.3 * commanded

    def set_velocity(self, robot: str, vx_mps: float, vyaw_radps: float) -> None:
        """Command forward and turn speed; clamped to the drive's limits."""
        st = self.world.device(robot, "position2d")
        p2d = st.spec.devices.position2d
        assert p2d is not None
        if not (math.isfinite(vx_mps) and math.isfinite(vyaw_radps)):
            raise ValueError("velocity must be finite")
        st.target_v = max(-p2d.max_speed_mps, min(p2d.max_speed_mps, float(vx_mps)))
        st.target_w = max(-p2d.max_yaw_rate_radps, min(p2d.max_yaw_rate_radps,
                                                       float(vyaw_radps)))

    def set_motor_power(self, robot: str, on: bool) -> None:
        self.world.device(robot, "position2d").motors_on = bool(on)

    def motor_power(self, robot: str) -> bool:
        return self.world.device(robot, "position2d").motors_on

    def drive_command(self, robot: str) -> tuple[float, float]:
        """The forward and turn speed the drive is steering towards now: the commanded
        velocity, or zero while the motors are off or the battery is flat."""
        st = self.world.device(robot, "position2d")
        if not st.motors_on or (st.battery is not None and st.battery.flat):
            return 0.0, 0.0
        return st.target_v, st.target_w

    def odometry(self, robot: str) -> Odometry:
        st = self.world.device(robot, "position2d")
        x, y, yaw = st.odom
        vx, vy, vyaw = st.odom_v
        return _make_odometry(x, y, yaw, vx, vy, vyaw, st.stall)

    def set_odometry(self, robot: str, x: float, y: float, yaw: float) -> None:
        st = self.world.device(robot, "position2d")
        st.odom = (float(x), float(y), wrap_angle(float(yaw)))
