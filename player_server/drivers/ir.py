"""Infrared proximity beams (`worlds.devices.ir`) as a Player ranger, ``ranger:1``.

Index 1 leaves ``ranger:0`` to a robot's scanning ranger. DATA is the beams' ranges (right to
left); GET_GEOM gives each beam's pose on the body's surface, GET_CONFIG the fan. The fan is
the world file's: SET_CONFIG is not supported (NACK).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack, declared
from player_server.drivers.geometry import mount_pose
from player_server.drivers.sim_port import device_model
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import Bbox3d, Pose3d
from player_server.protocol.constants import Interface
from worlds.devices.ir import IrSpec, surface_distance
from worlds.spec import Mount

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from player_server.sim.devices.ir import IrModel
    from worlds import RobotSpec

IR_SIZE = Bbox3d(0.01, 0.01, 0.01)


class IrDriver(Driver):
    device = "ir"
    interf = int(Interface.RANGER)
    requests = frozenset({c.PLAYER_RANGER_REQ_GET_GEOM, c.PLAYER_RANGER_REQ_GET_CONFIG,
                          c.PLAYER_RANGER_REQ_POWER})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 1) -> None:
        super().__init__(index, "sim_ir")
        self.sim = sim
        self.robot = robot
        self.spec: IrSpec = declared(robot.devices.get("ir"), f"robot {robot.name!r}", "ir")
        self.model = cast("IrModel", device_model(sim, "ir"))
        self.properties = {"max_range": float(self.spec.max_range_m)}

    def data(self) -> Sequence[tuple[int, Any]]:
        return ((c.PLAYER_RANGER_DATA_RANGE,
                 sm.RangerDataRange(self.model.ranges(self.robot.name))),)

    def geometry(self) -> sm.RangerGeom:
        body = self.robot.body
        beams = []
        for bearing in self.spec.bearings_rad():
            d = surface_distance(bearing, body.length_m / 2, body.width_m / 2)
            beams.append(mount_pose(Mount(body.offset_x_m + d * math.cos(bearing),
                                          d * math.sin(bearing), self.spec.z_m, bearing)))
        return sm.RangerGeom(Pose3d(0.0, 0.0, self.spec.z_m, 0.0, 0.0, 0.0), IR_SIZE,
                             tuple(beams), tuple(IR_SIZE for _ in beams))

    def config(self) -> sm.RangerConfig:
        s = self.spec
        bearings = s.bearings_rad()
        return sm.RangerConfig(bearings[0], bearings[-1], s.fov_rad / s.count, 0.0,
                               s.max_range_m, 0.001,
                               1.0 / float(self.sim.spec.sim.interval_sim_s))

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_RANGER_REQ_GET_GEOM:
            return ack(self.geometry())
        if subtype == c.PLAYER_RANGER_REQ_GET_CONFIG:
            return ack(self.config())
        if subtype == c.PLAYER_RANGER_REQ_POWER and body is not None:
            return ACK
        raise Unsupported(f"ranger request {subtype}")
