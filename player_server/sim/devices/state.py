"""Each robot's mutable state in the simulated world, as the device models see it.

The world owns one `RobotState` per robot (built from the world file, moved by the physics
each tick) and hands them to the models through `world.DeviceWorld`. The pose is the
drive-axle centre's; a model that keeps state of its own per robot either has a field here
(the built-in kinds, read on every tick) or keeps a dict by robot index.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from player_server.sim.battery import Battery
from worlds import RobotSpec


@dataclass
class Paddles:
    """A gripper's paddles and what they hold or store."""

    state: str = "open"
    target: str = "open"
    remaining_s: float = 0.0
    holding: str | None = None
    constraint: int = -1
    stored: list[str] = field(default_factory=list)


@dataclass
class PtzHead:
    """A pan-tilt-zoom head: where it points, where it is going and how fast it turns."""

    pan: float = 0.0
    tilt: float = 0.0
    zoom: float = 0.0
    pan_target: float = 0.0
    tilt_target: float = 0.0
    zoom_target: float = 0.0
    pan_speed: float = 0.0
    tilt_speed: float = 0.0


@dataclass
class RobotState:
    """One robot: its world-file entry, its PyBullet body, its true pose and drive state."""

    index: int
    spec: RobotSpec
    body: int
    rng: np.random.Generator
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    target_v: float = 0.0
    target_w: float = 0.0
    v: float = 0.0
    w: float = 0.0
    motors_on: bool = True
    odom: tuple[float, float, float] = (0.0, 0.0, 0.0)
    odom_v: tuple[float, float, float] = (0.0, 0.0, 0.0)
    stall: bool = False
    battery: Battery | None = None
    gripper: Paddles | None = None
    ptz: PtzHead | None = None
    z0: float = 0.0  # body-centre height it glides at
    z: float = 0.0
