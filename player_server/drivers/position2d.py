"""position2d: odometry out; velocity, position, car and heading commands in."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack, declared
from player_server.drivers.geometry import body_geometry, finite, wrap_angle
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol.common import Pose2d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec


# bodies built every tick: the positional constructors fill the slots directly
_MAKE_DATA = am.Position2dData.xdr_make  # type: ignore[attr-defined]
_MAKE_POSE = Pose2d.xdr_make  # type: ignore[attr-defined]

#: odometry coordinates a client may set or send as a goal (metres, either axis)
ODOM_LIMIT_M = 1.0e4

_NULL_REQUESTS = frozenset({
    c.PLAYER_POSITION2D_REQ_VELOCITY_MODE, c.PLAYER_POSITION2D_REQ_POSITION_MODE,
    c.PLAYER_POSITION2D_REQ_SPEED_PID, c.PLAYER_POSITION2D_REQ_POSITION_PID,
    c.PLAYER_POSITION2D_REQ_SPEED_PROF,
})


def _numbers(body: Any) -> list[float]:
    """Every float of a command body (nested poses included)."""
    out: list[float] = []
    for name in body.__slots__:
        v = getattr(body, name)
        if isinstance(v, float):
            out.append(v)
        elif hasattr(v, "__slots__"):
            out.extend(_numbers(v))
    return out


def _within_odometry(x: float, y: float) -> None:
    if abs(x) > ODOM_LIMIT_M or abs(y) > ODOM_LIMIT_M:
        raise ValueError(f"odometry position ({x:g}, {y:g}) is beyond +-{ODOM_LIMIT_M:g} m")


class Position2dDriver(Driver):
    """Differential drive. Position (CMD POS) and heading (CMD VEL_HEAD) goals are followed
    by a proportional controller that sets the velocity before every simulation step."""

    device = "position2d"
    interf = int(Interface.POSITION2D)
    commands = frozenset({1, 2, 3, 4})
    deferred_commands = commands  # velocity targets and goals, followed from the next step
    requests = frozenset(range(1, 10))
    watched = True  # a robot whose driving client goes silent stops

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_position2d")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.position2d, f"robot {robot.name!r}", "position2d")
        self.properties = {
            "max_speed": float(self.spec.max_speed_mps),
            "max_yaw_rate": float(self.spec.max_yaw_rate_radps),
            "position_tolerance_m": 0.05,
            "heading_tolerance_rad": 0.05,
        }
        self.property_limits = {
            "max_speed": (0.0, float(self.spec.max_speed_mps)),
            "max_yaw_rate": (0.0, float(self.spec.max_yaw_rate_radps)),
            "position_tolerance_m": (1e-3, 10.0),
            "heading_tolerance_rad": (1e-3, math.pi),
        }
        self._goal: tuple[str, tuple[float, ...]] | None = None
        self._geom = am.Position2dGeom(*body_geometry(robot))  # fixed by the world

    def data(self) -> Sequence[tuple[int, Any]]:
        o = self.sim.odometry(self.robot.name)
        return ((c.PLAYER_POSITION2D_DATA_STATE, _MAKE_DATA(
            _MAKE_POSE(o.x, o.y, o.yaw), _MAKE_POSE(o.vx, o.vy, o.vyaw), 1 if o.stall else 0)),)

    def _clamp(self, vx: float, vyaw: float) -> tuple[float, float]:
        vmax = float(self.properties["max_speed"])
        wmax = float(self.properties["max_yaw_rate"])
        return max(-vmax, min(vmax, vx)), max(-wmax, min(wmax, vyaw))

    def handle_command(self, subtype: int, body: Any) -> None:
        name = self.robot.name
        if body is None:
            raise Unsupported("position2d commands need a body")
        if subtype == c.PLAYER_POSITION2D_CMD_VEL:  # the usual command, checked directly
            v = body.vel
            finite(float(v.px), float(v.py), float(v.pa))
            self._goal = None
            vx, vyaw = self._clamp(v.px, v.pa)
            self.sim.set_velocity(name, vx, vyaw)
            return
        finite(*(float(n) for n in _numbers(body)))
        if subtype == c.PLAYER_POSITION2D_CMD_POS:
            _within_odometry(body.pos.px, body.pos.py)
            self._goal = ("pos", (body.pos.px, body.pos.py, body.pos.pa,
                                  abs(body.vel.px) or float(self.properties["max_speed"])))
        elif subtype == c.PLAYER_POSITION2D_CMD_CAR:
            self._goal = None
            wheelbase_m = max(float(self.robot.body.length_m), 1e-3)
            vyaw = body.velocity * math.tan(body.angle) / wheelbase_m
            self.sim.set_velocity(name, *self._clamp(body.velocity, vyaw))
        elif subtype == c.PLAYER_POSITION2D_CMD_VEL_HEAD:
            self._goal = ("head", (body.velocity, body.angle))
        else:
            raise Unsupported(f"position2d command {subtype}")

    def watchdog_stop(self) -> None:
        self._goal = None
        self.sim.set_velocity(self.robot.name, 0.0, 0.0)

    def before_step(self) -> None:
        if self._goal is None:
            return
        kind, g = self._goal
        o = self.sim.odometry(self.robot.name)
        if kind == "head":
            err = wrap_angle(g[1] - o.yaw)
            self.sim.set_velocity(self.robot.name, *self._clamp(g[0], 2.0 * err))
            return
        gx, gy, gyaw, speed = g
        dx, dy = gx - o.x, gy - o.y
        dist = math.hypot(dx, dy)
        if dist > float(self.properties["position_tolerance_m"]):
            err = wrap_angle(math.atan2(dy, dx) - o.yaw)
            vx = min(speed, 1.5 * dist) * max(0.0, math.cos(err)) ** 2
            self.sim.set_velocity(self.robot.name, *self._clamp(vx, 2.0 * err))
            return
        err = wrap_angle(gyaw - o.yaw)
        if abs(err) > float(self.properties["heading_tolerance_rad"]):
            self.sim.set_velocity(self.robot.name, *self._clamp(0.0, 2.0 * err))
            return
        self.sim.set_velocity(self.robot.name, 0.0, 0.0)
        self._goal = None

    def handle_request(self, subtype: int, body: Any) -> Reply:
        name = self.robot.name
        if subtype == c.PLAYER_POSITION2D_REQ_GET_GEOM:
            return ack(self._geom)
        if subtype == c.PLAYER_POSITION2D_REQ_MOTOR_POWER:
            self.sim.set_motor_power(name, bool(body.state))
            return ACK
        if subtype == c.PLAYER_POSITION2D_REQ_SET_ODOM:
            finite(body.pose.px, body.pose.py, body.pose.pa)
            _within_odometry(body.pose.px, body.pose.py)
            self.sim.set_odometry(name, body.pose.px, body.pose.py, body.pose.pa)
            return ACK
        if subtype == c.PLAYER_POSITION2D_REQ_RESET_ODOM:
            self.sim.set_odometry(name, 0.0, 0.0, 0.0)
            return ACK
        if subtype in _NULL_REQUESTS and body is not None:
            return ACK
        raise Unsupported(f"position2d request {subtype}")
