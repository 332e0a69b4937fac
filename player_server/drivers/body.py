"""Devices of the robot's body: gripper, bumper ring and battery (power)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack, declared
from player_server.drivers.geometry import mount_pose
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d, Pose3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec


# bodies built every tick: the positional constructors fill the slots directly
_MAKE_GRIPPER = am.GripperData.xdr_make  # type: ignore[attr-defined]
_MAKE_BUMPER = sm.BumperData.xdr_make  # type: ignore[attr-defined]
_MAKE_POWER = am.PowerData.xdr_make  # type: ignore[attr-defined]

_GRIPPER_STATES = {
    "open": c.PLAYER_GRIPPER_STATE_OPEN,
    "closed": c.PLAYER_GRIPPER_STATE_CLOSED,
    "moving": c.PLAYER_GRIPPER_STATE_MOVING,
}
_GRIPPER_COMMANDS = {
    c.PLAYER_GRIPPER_CMD_OPEN: "open",
    c.PLAYER_GRIPPER_CMD_CLOSE: "close",
    c.PLAYER_GRIPPER_CMD_STOP: "stop",
    c.PLAYER_GRIPPER_CMD_STORE: "store",
    c.PLAYER_GRIPPER_CMD_RETRIEVE: "retrieve",
}


class GripperDriver(Driver):
    device = "gripper"
    interf = int(Interface.GRIPPER)
    commands = frozenset(_GRIPPER_COMMANDS)
    requests = frozenset({c.PLAYER_GRIPPER_REQ_GET_GEOM})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_gripper")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.gripper, f"robot {robot.name!r}", "gripper")

    def data(self) -> Sequence[tuple[int, Any]]:
        g = self.sim.gripper(self.robot.name)
        state = _GRIPPER_STATES.get(g.state, c.PLAYER_GRIPPER_STATE_ERROR)
        return ((c.PLAYER_GRIPPER_DATA_STATE, _MAKE_GRIPPER(state, int(g.beams),
                                                            int(g.stored))),)

    def handle_command(self, subtype: int, body: Any) -> None:
        action = _GRIPPER_COMMANDS.get(subtype)
        if action is None:
            raise Unsupported(f"gripper command {subtype}")
        self.sim.gripper_command(self.robot.name, action)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_GRIPPER_REQ_GET_GEOM:
            s = self.spec
            outer = Bbox3d(s.width_m + 0.04, s.depth_m + 0.02, 0.1)
            inner = Bbox3d(s.width_m, s.depth_m, 0.08)
            return ack(am.GripperGeom(mount_pose(s.pose), outer, inner, 2, int(s.capacity)))
        raise Unsupported(f"gripper request {subtype}")


class BumperDriver(Driver):
    device = "bumper"
    interf = int(Interface.BUMPER)
    requests = frozenset({c.PLAYER_BUMPER_REQ_GET_GEOM})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_bumper")
        self.sim = sim
        self.robot = robot
        self.spec = declared(robot.devices.bumper, f"robot {robot.name!r}", "bumper")

    def data(self) -> Sequence[tuple[int, Any]]:
        states = bytes([1 if b else 0 for b in self.sim.bumpers(self.robot.name)])
        return ((c.PLAYER_BUMPER_DATA_STATE, _MAKE_BUMPER(states)),)

    def geometry(self) -> sm.BumperGeom:
        return sm.BumperGeom(tuple(
            sm.BumperDefine(Pose3d(seg.x, seg.y, 0.0, 0.0, 0.0, seg.yaw), seg.length_m,
                            seg.radius_m)
            for seg in self.spec.segments))

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_BUMPER_REQ_GET_GEOM:
            return ack(self.geometry())
        raise Unsupported(f"bumper request {subtype}")


_VALID_ALL = (c.PLAYER_POWER_MASK_VOLTS | c.PLAYER_POWER_MASK_WATTS | c.PLAYER_POWER_MASK_JOULES
              | c.PLAYER_POWER_MASK_PERCENT | c.PLAYER_POWER_MASK_CHARGING)


class PowerDriver(Driver):
    """The battery. ``watts`` is the draw (negative = consuming); ``charging`` 1 on a pad.

    SET_CHARGING_POLICY is kept and reported in the ``enable_input`` / ``enable_output``
    properties; when the simulator offers ``set_charging_enabled`` it is applied there.
    """

    device = "power"
    interf = int(Interface.POWER)
    requests = frozenset({c.PLAYER_POWER_REQ_SET_CHARGING_POLICY})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_power")
        self.sim = sim
        self.robot = robot
        self.properties = {"enable_input": True, "enable_output": True}

    def data(self) -> Sequence[tuple[int, Any]]:
        p = self.sim.power(self.robot.name)
        watts = -abs(float(p.watts))  # the draw, as Player's "negative = consuming"
        charging = 1 if p.charging else 0
        return ((c.PLAYER_POWER_DATA_STATE, _MAKE_POWER(
            _VALID_ALL, p.volts, p.percent, p.joules, watts, charging)),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_POWER_REQ_SET_CHARGING_POLICY and body is not None:
            self.properties["enable_input"] = bool(body.enable_input)
            self.properties["enable_output"] = bool(body.enable_output)
            setter = getattr(self.sim, "set_charging_enabled", None)
            if setter is not None:
                setter(self.robot.name, bool(body.enable_input))
            return ACK
        raise Unsupported(f"power request {subtype}")
