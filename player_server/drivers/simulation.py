"""The simulation interface: ground-truth poses by name, pause, reset. It has no DATA."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack
from player_server.drivers.geometry import finite
from player_server.drivers.sim_properties import model_property, property_change
from player_server.protocol import constants as c
from player_server.protocol import simulation_msgs as simm
from player_server.protocol.common import Pose2d, Pose3d
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.drivers.sim_port import WorldPort


log = logging.getLogger(__name__)


#: what changes the world: allowed to network clients only when the server says so
WORLD_CONTROL_COMMANDS = frozenset({c.PLAYER_SIMULATION_CMD_PAUSE, c.PLAYER_SIMULATION_CMD_RESET})
WORLD_CONTROL_REQUESTS = frozenset({c.PLAYER_SIMULATION_REQ_SET_POSE2D,
                                    c.PLAYER_SIMULATION_REQ_SET_POSE3D,
                                    c.PLAYER_SIMULATION_REQ_SET_PROPERTY})


class WorldControlRefused(ValueError):
    """A world-changing request or command while world control is not allowed."""


class SimulationDriver(Driver):
    """Ground-truth poses for every client; pausing, resetting and moving bodies only with
    ``world_control`` (``player-server --allow-world-control``)."""

    interf = int(Interface.SIMULATION)
    commands = frozenset({c.PLAYER_SIMULATION_CMD_PAUSE, c.PLAYER_SIMULATION_CMD_RESET,
                          c.PLAYER_SIMULATION_CMD_SAVE})
    requests = frozenset({1, 2, 3, 4, 5, 6})

    def __init__(self, sim: WorldPort, index: int = 0, *, world_control: bool = False,
                 fixed: Mapping[str, tuple[float, float, float]] | None = None) -> None:
        super().__init__(index, "sim_simulation")
        self.sim = sim
        self.world_control = world_control
        self.refused = 0
        #: names of things that do not move here (a Stage world's obstacles, floorplans,
        #: zones) and their poses: readable, not movable
        self.fixed = dict(fixed or {})

    def _pose(self, name: str) -> tuple[float, float, float]:
        try:
            return self.sim.get_pose(name)
        except KeyError:
            if name in self.fixed:
                x, y, yaw = self.fixed[name]
                return (float(x), float(y), float(yaw))
            raise

    def _check_control(self, what: str) -> None:
        if not self.world_control:
            self.refused += 1
            raise WorldControlRefused(
                f"{what} changes the world; the server allows it only with "
                "--allow-world-control")

    def _check_pose(self, name: str, x: float, y: float, yaw: float) -> None:
        finite(x, y, yaw)
        arena = self.sim.spec.arena
        if abs(x) > arena.half_x_m or abs(y) > arena.half_y_m:
            raise ValueError(f"pose ({x:g}, {y:g}) of {name!r} is outside the "
                             f"{arena.size_x_m:g} x {arena.size_y_m:g} m arena")

    def handle_command(self, subtype: int, body: Any) -> None:
        if subtype in WORLD_CONTROL_COMMANDS:
            self._check_control(f"simulation command {subtype}")
        if subtype == c.PLAYER_SIMULATION_CMD_PAUSE:
            self.sim.set_paused(not self.sim.paused)
            log.info("simulation %s", "paused" if self.sim.paused else "resumed")
        elif subtype == c.PLAYER_SIMULATION_CMD_RESET:
            self.sim.reset()
            log.info("simulation reset")
        elif subtype == c.PLAYER_SIMULATION_CMD_SAVE:
            log.info("simulation SAVE is not supported; ignored")
        else:
            raise Unsupported(f"simulation command {subtype}")

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if body is None:
            raise Unsupported("simulation requests need a body")
        if subtype == c.PLAYER_SIMULATION_REQ_GET_POSE2D:
            x, y, yaw = self._pose(body.name)
            return ack(simm.SimulationPose2dReq(body.name, Pose2d(x, y, yaw)))
        if subtype in WORLD_CONTROL_REQUESTS:
            self._check_control(f"simulation request {subtype}")
        if subtype == c.PLAYER_SIMULATION_REQ_SET_POSE2D:
            self._check_pose(body.name, body.pose.px, body.pose.py, body.pose.pa)
            self.sim.set_pose(body.name, body.pose.px, body.pose.py, body.pose.pa)
            return ACK
        if subtype == c.PLAYER_SIMULATION_REQ_GET_POSE3D:
            x, y, yaw = self._pose(body.name)
            return ack(simm.SimulationPose3dReq(
                body.name, Pose3d(x, y, 0.0, 0.0, 0.0, yaw), float(self.sim.time_s)))
        if subtype == c.PLAYER_SIMULATION_REQ_SET_POSE3D:
            self._check_pose(body.name, body.pose.px, body.pose.py, body.pose.pyaw)
            self.sim.set_pose(body.name, body.pose.px, body.pose.py, body.pose.pyaw)
            return ACK
        if subtype == c.PLAYER_SIMULATION_REQ_GET_PROPERTY:
            return ack(replace(body, value=model_property(self.sim.spec, body.name, body.prop,
                                                          self.sim.looks)))
        if subtype == c.PLAYER_SIMULATION_REQ_SET_PROPERTY:
            change = property_change(body.prop, bytes(body.value))
            self.sim.set_looks(body.name, **change)
            return ACK
        raise Unsupported(f"simulation request {subtype}")
