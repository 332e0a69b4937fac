"""What drivers need from the simulator: the seam between Player devices and the world.

`player_server.sim.Simulation` satisfies `SimPort`; a driver holds one and never reaches past
it. Readings are the simulator's plain values (`player_server.sim.readings`), which drivers
turn into Player bodies. The overhead drivers need only `OverheadPort`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from player_server.sim.devices.base import DeviceModel
    from player_server.sim.looks import Looks
    from player_server.sim.readings import (
        Blob,
        Fiducial,
        GripperState,
        Odometry,
        PowerState,
        PtzState,
        TrackedObject,
    )
    from worlds import WorldSpec


class ClockPort(Protocol):
    """The simulated clock and its pause switch."""

    @property
    def time_s(self) -> float: ...

    @property
    def tick(self) -> int: ...

    @property
    def paused(self) -> bool: ...

    def set_paused(self, paused: bool) -> None: ...


class WorldPort(ClockPort, Protocol):
    """Ground truth and world control (the simulation interface)."""

    @property
    def spec(self) -> WorldSpec: ...

    def step(self, n: int = 1) -> int: ...

    def reset(self, seed: int | None = None) -> None: ...

    def get_pose(self, name: str) -> tuple[float, float, float]: ...

    def set_pose(self, name: str, x: float, y: float, yaw: float) -> None: ...

    @property
    def looks(self) -> Looks: ...

    def set_looks(self, name: str, colour: int | None = None,
                  fiducial_id: int | None = None) -> None: ...


class OverheadPort(ClockPort, Protocol):
    """What the overhead camera's drivers read."""

    def overhead(self) -> tuple[TrackedObject, ...]: ...


class SimPort(WorldPort, OverheadPort, Protocol):
    """Everything a robot's drivers read from and command to the simulator, by robot name."""

    def set_velocity(self, robot: str, vx_mps: float, vyaw_radps: float) -> None: ...

    def set_motor_power(self, robot: str, on: bool) -> None: ...

    def odometry(self, robot: str) -> Odometry: ...

    def set_odometry(self, robot: str, x: float, y: float, yaw: float) -> None: ...

    def sonar(self, robot: str) -> NDArray[np.float32]: ...

    def laser(self, robot: str) -> NDArray[np.float32]: ...

    def ranger(self, robot: str) -> NDArray[np.float64]: ...

    def set_scan_fan(self, robot: str, kind: str, fan: tuple[float, float, int] | None
                     ) -> None: ...

    def blobs(self, robot: str) -> tuple[Blob, ...]: ...

    def camera_image(self, robot: str) -> NDArray[np.uint8]: ...

    def bumpers(self, robot: str) -> tuple[bool, ...]: ...

    def gripper(self, robot: str) -> GripperState: ...

    def gripper_command(self, robot: str, command: str) -> None: ...

    def ptz(self, robot: str) -> PtzState: ...

    def ptz_command(self, robot: str, pan: float, tilt: float, zoom: float) -> None: ...

    def power(self, robot: str) -> PowerState: ...

    def fiducials(self, robot: str) -> tuple[Fiducial, ...]: ...

    @property
    def models(self) -> tuple[DeviceModel, ...]:
        """The world's device models: the driver of a kind with no method above reads its
        model's (`device_model`)."""
        ...


def device_model(sim: SimPort, kind: str) -> DeviceModel:
    """The model simulating the device kind `kind` (KeyError if none); a driver types it with
    a `TYPE_CHECKING` import of the model's class."""
    for model in sim.models:
        if kind in model.kinds:
            return model
    raise KeyError(f"no device model simulates {kind!r}")
