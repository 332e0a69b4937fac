"""Inertial measurement units (`worlds.devices.imu`): the motion of a point on the body.

Each tick the model reads the body's velocity from PyBullet (the linear velocity of its
centre and its spin, what the physics left after contacts; a teleported body is at rest) and
keeps the unit's velocity in the world; its acceleration is the change over the tick, turned
into the unit's frame at the tick's mid heading, so that a turning robot feels the
centripetal v * w to its left. Both fidelities move the same PyBullet bodies, so they read
the same. The heading is the true yaw less the reference a reset took, plus the drift since
then; the noise of a tick is drawn from the world's noise seed, the tick and the robot, so a
reading does not depend on who read what before it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar, NamedTuple, cast

import numpy as np
import pybullet as pb

from worlds.devices.imu import ImuSpec

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState
    from player_server.sim.devices.world import DeviceWorld

GRAVITY_MPS2 = 9.81
_NOISE_STREAM = 0x1A0
"""Sets the units' noise apart from other draws of the same tick."""


class ImuReading(NamedTuple):
    """One tick of a unit, in its own frame (x ahead, y left, z up)."""

    yaw: float
    """Heading (rad): the world's yaw, or since the last reset."""
    gyro: tuple[float, float, float]
    """Turn rates about x, y, z (rad/s)."""
    accel: tuple[float, float, float]
    """Specific force (m/s^2): the acceleration, plus gravity's reaction on z."""
    vel: tuple[float, float, float]
    """The unit's true velocity (m/s)."""
    yaw_accel: float
    """Change of the turn rate (rad/s^2)."""


class _Unit:
    """What the model keeps of one unit between ticks."""

    __slots__ = ("accel", "reset_s", "vel", "w", "w_dot", "yaw", "yaw_ref")

    def __init__(self, yaw: float) -> None:
        self.vel = (0.0, 0.0)
        self.accel = (0.0, 0.0)
        self.w = 0.0
        self.w_dot = 0.0
        self.yaw = yaw
        self.yaw_ref = 0.0
        self.reset_s = 0.0


class ImuModel:
    kinds: ClassVar[tuple[str, ...]] = ("imu",)
    order: ClassVar[int] = 100
    ticking: ClassVar[bool] = True

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world
        self.units: dict[int, _Unit] = {}

    def build(self) -> None:
        self.units = {st.index: _Unit(st.yaw) for st in self.world.robots
                      if st.spec.devices.get("imu") is not None}

    def advance(self, dt: float) -> None:
        for st in self.world.robots:
            unit = self.units.get(st.index)
            if unit is not None:
                self._advance(st, unit, dt)

    def _advance(self, st: RobotState, unit: _Unit, dt: float) -> None:
        spec = cast(ImuSpec, st.spec.devices.get("imu"))
        lin, ang = pb.getBaseVelocity(st.body, physicsClientId=self.world.physics_client)
        w = float(ang[2])
        # the unit's offset from the body centre, turned into the world
        rx, ry = spec.pose.x - st.spec.body.offset_x_m, spec.pose.y
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        vx = float(lin[0]) - w * (s * rx + c * ry)
        vy = float(lin[1]) + w * (c * rx - s * ry)
        ax, ay = (vx - unit.vel[0]) / dt, (vy - unit.vel[1]) / dt
        mid = unit.yaw + 0.5 * math.atan2(math.sin(st.yaw - unit.yaw),
                                          math.cos(st.yaw - unit.yaw)) + spec.pose.yaw
        cm, sm = math.cos(mid), math.sin(mid)
        unit.accel = (cm * ax + sm * ay, -sm * ax + cm * ay)
        unit.w_dot = (w - unit.w) / dt
        unit.vel, unit.w, unit.yaw = (vx, vy), w, st.yaw

    def reset_orientation(self, robot: str) -> None:
        """The heading reads 0 from now on (and drifts from now)."""
        st = self.world.device(robot, "imu")
        unit = self.units[st.index]
        unit.yaw_ref = st.yaw
        unit.reset_s = self.world.tick * self.world.spec.sim.interval_sim_s
        self.world.invalidate()

    def reading(self, robot: str) -> ImuReading:
        """This tick's measures of the robot's unit."""
        w = self.world
        st = w.device(robot, "imu")

        def compute() -> ImuReading:
            spec = cast(ImuSpec, st.spec.devices.get("imu"))
            unit = self.units[st.index]
            now_s = w.tick * w.spec.sim.interval_sim_s
            noise = np.random.default_rng(
                [w.noise_seed, w.tick, st.index, _NOISE_STREAM]).standard_normal(7)
            yaw = (st.yaw + spec.pose.yaw - unit.yaw_ref
                   + spec.yaw_drift_radps * (now_s - unit.reset_s)
                   + spec.yaw_noise_rad * float(noise[0]))
            g, a = spec.gyro_noise_radps, spec.accel_noise_mps2
            cy, sy = math.cos(st.yaw + spec.pose.yaw), math.sin(st.yaw + spec.pose.yaw)
            vx, vy = unit.vel
            return ImuReading(
                math.atan2(math.sin(yaw), math.cos(yaw)),
                (g * float(noise[1]), g * float(noise[2]), unit.w + g * float(noise[3])),
                (unit.accel[0] + a * float(noise[4]), unit.accel[1] + a * float(noise[5]),
                 GRAVITY_MPS2 + a * float(noise[6])),
                (cy * vx + sy * vy, -sy * vx + cy * vy, 0.0),
                unit.w_dot)

        return w.cached(("imu", st.index), compute)  # type: ignore[return-value]
