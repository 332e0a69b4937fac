"""The device models of the simulator, one module per kind, and their registry.

`DEVICE_MODELS` maps each device name of the world file to the model that simulates it;
`MODEL_CLASSES` lists the models in the order the world builds and advances them. A new
device kind is one module here (a class with the `base.DeviceModel` interface) and one entry
in `MODEL_CLASSES`; see docs/internals.md for the driver, proxy and world-file entry.
"""

from __future__ import annotations

from player_server.sim.devices.base import DeviceModel
from player_server.sim.devices.bumper import BumperModel
from player_server.sim.devices.camera import CameraModel
from player_server.sim.devices.gripper import GripperModel
from player_server.sim.devices.position2d import Position2dModel
from player_server.sim.devices.power import PowerModel
from player_server.sim.devices.ptz import PtzModel
from player_server.sim.devices.ranging import RangeModel
from player_server.sim.devices.tracking import TrackingModel

MODEL_CLASSES: tuple[type[DeviceModel], ...] = (
    Position2dModel, PowerModel, GripperModel, PtzModel, BumperModel, RangeModel, CameraModel,
    TrackingModel,
)
DEVICE_MODELS: dict[str, type[DeviceModel]] = {
    kind: cls for cls in MODEL_CLASSES for kind in cls.kinds
}

__all__ = ["DEVICE_MODELS", "MODEL_CLASSES", "DeviceModel"]
