"""The simulation interface: ground-truth poses by name, pause, reset. It has no DATA."""

from __future__ import annotations

import logging
from typing import Any

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack
from player_server.drivers.geometry import finite
from player_server.protocol import constants as c
from player_server.protocol import simulation_msgs as simm
from player_server.protocol.common import Pose2d, Pose3d
from player_server.protocol.constants import Interface

log = logging.getLogger(__name__)


class SimulationDriver(Driver):
    interf = int(Interface.SIMULATION)
    commands = frozenset({c.PLAYER_SIMULATION_CMD_PAUSE, c.PLAYER_SIMULATION_CMD_RESET,
                          c.PLAYER_SIMULATION_CMD_SAVE})
    requests = frozenset({1, 2, 3, 4})

    def __init__(self, sim: Any, index: int = 0) -> None:
        super().__init__(index, "sim_simulation")
        self.sim = sim

    def handle_command(self, subtype: int, body: Any) -> None:
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
            x, y, yaw = self.sim.get_pose(body.name)
            return ack(simm.SimulationPose2dReq(body.name, Pose2d(x, y, yaw)))
        if subtype == c.PLAYER_SIMULATION_REQ_SET_POSE2D:
            finite(body.pose.px, body.pose.py, body.pose.pa)
            self.sim.set_pose(body.name, body.pose.px, body.pose.py, body.pose.pa)
            return ACK
        if subtype == c.PLAYER_SIMULATION_REQ_GET_POSE3D:
            x, y, yaw = self.sim.get_pose(body.name)
            return ack(simm.SimulationPose3dReq(
                body.name, Pose3d(x, y, 0.0, 0.0, 0.0, yaw), float(self.sim.time_s)))
        if subtype == c.PLAYER_SIMULATION_REQ_SET_POSE3D:
            finite(body.pose.px, body.pose.py, body.pose.pyaw)
            self.sim.set_pose(body.name, body.pose.px, body.pose.py, body.pose.pyaw)
            return ACK
        raise Unsupported(f"simulation request {subtype}")
