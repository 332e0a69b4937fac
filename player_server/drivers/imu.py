"""An inertial measurement unit (`worlds.devices.imu`) as a Player imu, ``imu:0``.

DATA is one of the interface's five layouts at a time, the world file's `datatype` until a
client sends SET_DATATYPE (its value is the DATA subtype, 1-5; anything else is NACKed):

1. STATE: the pose; a unit measures no position, so px, py, pz are 0, and the angles are
   the heading (pyaw; roll and pitch 0 on the flat floor);
2. CALIB: accelerations (gravity's reaction on z) and turn rates in the unit's frame, no
   magnetometer (0);
3. QUAT: CALIB and the heading as a quaternion (q0 the scalar);
4. EULER: CALIB and the heading as roll, pitch, yaw;
5. FULLSTATE: the pose as in STATE, the unit's velocity in its frame with the turn rates,
   and its accelerations with the change of the turn rate (acc.pyaw).

RESET_ORIENTATION makes the heading read 0 from then on. Both requests get an empty ACK,
as Player's IMU drivers give; the data type belongs to the device, so every client of the
robot sees it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, declared
from player_server.drivers.sim_port import device_model
from player_server.protocol import constants as c
from player_server.protocol import imu_msgs as im
from player_server.protocol.common import Pose3d
from player_server.protocol.constants import Interface
from worlds.devices.imu import ImuSpec

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from player_server.sim.devices.imu import ImuModel, ImuReading
    from worlds import RobotSpec

DATATYPES = range(c.PLAYER_IMU_DATA_STATE, c.PLAYER_IMU_DATA_FULLSTATE + 1)


class ImuDriver(Driver):
    device = "imu"
    interf = int(Interface.IMU)
    requests = frozenset({c.PLAYER_IMU_REQ_SET_DATATYPE, c.PLAYER_IMU_REQ_RESET_ORIENTATION})

    def __init__(self, sim: SimPort, robot: RobotSpec, index: int = 0) -> None:
        super().__init__(index, "sim_imu")
        self.robot = robot
        self.spec: ImuSpec = declared(robot.devices.get("imu"), f"robot {robot.name!r}", "imu")
        self.model = cast("ImuModel", device_model(sim, "imu"))
        self.datatype = self.spec.datatype

    def data(self) -> Sequence[tuple[int, Any]]:
        return ((self.datatype, body(self.datatype, self.model.reading(self.robot.name))),)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == c.PLAYER_IMU_REQ_SET_DATATYPE and body is not None:
            if body.value not in DATATYPES:
                raise Unsupported(f"imu data type {body.value}")
            self.datatype = int(body.value)
            return ACK
        if subtype == c.PLAYER_IMU_REQ_RESET_ORIENTATION and body is not None:
            self.model.reset_orientation(self.robot.name)
            return ACK
        raise Unsupported(f"imu request {subtype}")


def body(datatype: int, r: ImuReading) -> Any:
    """The DATA body of `datatype` from one reading."""
    pose = Pose3d(0.0, 0.0, 0.0, 0.0, 0.0, r.yaw)
    if datatype == c.PLAYER_IMU_DATA_STATE:
        return im.ImuDataState(pose)
    if datatype == c.PLAYER_IMU_DATA_FULLSTATE:
        return im.ImuDataFullstate(pose, Pose3d(*r.vel, *r.gyro), Pose3d(*r.accel, 0.0, 0.0,
                                                                          r.yaw_accel))
    calib = im.ImuDataCalib(*r.accel, *r.gyro, 0.0, 0.0, 0.0)
    if datatype == c.PLAYER_IMU_DATA_CALIB:
        return calib
    if datatype == c.PLAYER_IMU_DATA_QUAT:
        return im.ImuDataQuat(calib, math.cos(r.yaw / 2), 0.0, 0.0, math.sin(r.yaw / 2))
    return im.ImuDataEuler(calib, im.Orientation3d(0.0, 0.0, r.yaw))
