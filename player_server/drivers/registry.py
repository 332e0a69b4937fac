"""Which drivers a robot (or the overhead camera) gets, from its world spec."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from player_server.drivers.base import Driver
from player_server.drivers.body import BumperDriver, GripperDriver, PowerDriver
from player_server.drivers.overhead import (
    OverheadBlobfinderDriver,
    OverheadCameraDriver,
    OverheadFiducialDriver,
)
from player_server.drivers.position2d import Position2dDriver
from player_server.drivers.ranging import LaserDriver, RangerDriver, SonarDriver
from player_server.drivers.simulation import SimulationDriver
from player_server.drivers.vision import (
    BlobfinderDriver,
    CameraDriver,
    FiducialDriver,
    PtzDriver,
)

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec, WorldSpec

DeviceKey = tuple[int, int]

_BY_DEVICE: dict[str, Any] = {
    "position2d": Position2dDriver,
    "sonar": SonarDriver,
    "laser": LaserDriver,
    "ranger": RangerDriver,
    "camera": CameraDriver,
    "blobfinder": BlobfinderDriver,
    "bumper": BumperDriver,
    "gripper": GripperDriver,
    "ptz": PtzDriver,
    "power": PowerDriver,
    "fiducial": FiducialDriver,
}


def driver_class(device: str) -> Any:
    """The driver class serving a `DeviceSet` slot (KeyError if none)."""
    return _BY_DEVICE[device]


def _keyed(drivers: list[Driver]) -> dict[DeviceKey, Driver]:
    return {(d.interf, d.index): d for d in drivers}


def robot_drivers(sim: SimPort, robot: RobotSpec, *, world_control: bool = False
                  ) -> dict[DeviceKey, Driver]:
    """Drivers for every device the robot declares, plus simulation:0 (which pauses, resets
    and moves bodies only with ``world_control``)."""
    drivers: list[Driver] = []
    for name in robot.devices.names():
        cls = _BY_DEVICE.get(name)
        if cls is None:
            raise ValueError(f"robot {robot.name!r}: no driver for device {name!r}")
        drivers.append(cls(sim, robot))
    drivers.append(SimulationDriver(sim, world_control=world_control))
    return _keyed(drivers)


def overhead_drivers(sim: SimPort, world: WorldSpec, *, world_control: bool = False
                     ) -> dict[DeviceKey, Driver]:
    """Camera:0, blobfinder:0, fiducial:0 and simulation:0 of the overhead camera."""
    return _keyed([OverheadCameraDriver(sim, world), OverheadBlobfinderDriver(sim, world),
                   OverheadFiducialDriver(sim, world),
                   SimulationDriver(sim, world_control=world_control)])
