"""Which drivers a robot (or the overhead camera) gets, from its world spec."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import Driver
from player_server.drivers.overhead import (
    OverheadBlobfinderDriver,
    OverheadCameraDriver,
    OverheadFiducialDriver,
)
from player_server.drivers.simulation import SimulationDriver

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import RobotSpec, WorldSpec

DeviceKey = tuple[int, int]


def _robot_device_drivers() -> dict[str, Any]:
    """The driver of each device kind: every `Driver` subclass of the modules of this package
    that names a `device` (a new kind's driver module is found here, not listed)."""
    found: dict[str, Any] = {}
    for mod in sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])):
        module = importlib.import_module(f"{__package__}.{mod}")
        for obj in vars(module).values():
            if (isinstance(obj, type) and issubclass(obj, Driver) and obj.device
                    and obj.__module__ == module.__name__):
                if found.get(obj.device, obj) is not obj:
                    raise ValueError(f"device {obj.device!r} has two drivers: "
                                     f"{found[obj.device].__qualname__}, {obj.__qualname__}")
                found[obj.device] = obj
    return found


_BY_DEVICE: dict[str, Any] = _robot_device_drivers()


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
