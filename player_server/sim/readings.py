"""Plain, frozen reading values returned by the simulator (no Player types here).

The simulator builds thousands of readings per simulated second with `fast_constructor`
(`player_server.frozen.frozen_constructor`).
"""

from __future__ import annotations

from dataclasses import dataclass

from player_server.frozen import frozen_constructor

fast_constructor = frozen_constructor

__all__ = [
    "Blob",
    "BodyPose",
    "Fiducial",
    "GripperState",
    "Odometry",
    "PowerState",
    "PtzState",
    "SceneSnapshot",
    "TrackedObject",
]
"""The reading types (what `player_server.sim` re-exports)."""


@dataclass(frozen=True)
class Odometry:
    """Odometric pose (may drift from ground truth) and velocity in the robot frame."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    vyaw: float
    stall: bool


@dataclass(frozen=True)
class Blob:
    """One colour blob: channel id, colour 0xRRGGBB, pixel area, centroid, box, range (m)."""

    id: int
    colour: int
    area: int
    x: int
    y: int
    l: int
    r: int
    t: int
    b: int
    range_m: float


@dataclass(frozen=True)
class GripperState:
    """Paddle state ("open" | "closed" | "moving"), break-beam bits, held and stored objects.

    beams: bit 0 = an object is between the paddles, bit 1 = the paddles hold an object.
    """

    state: str
    beams: int
    holding: str | None
    stored: int
    capacity: int


@dataclass(frozen=True)
class PtzState:
    """Current pan/tilt (rad), zoom as horizontal field of view (rad), and their speeds."""

    pan: float
    tilt: float
    zoom: float
    pan_speed: float
    tilt_speed: float


@dataclass(frozen=True)
class PowerState:
    volts: float
    percent: float
    joules: float
    watts: float
    charging: bool


@dataclass(frozen=True)
class TrackedObject:
    """A thing seen by the overhead camera: kind is "robot", "box", "object" or "marker"."""

    name: str
    kind: str
    colour: int
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class Fiducial:
    """A fiducial seen by a robot, relative to the detector: position, bearing, range."""

    id: int
    x: float
    y: float
    yaw: float
    range_m: float
    bearing_rad: float


@dataclass(frozen=True)
class BodyPose:
    name: str
    kind: str
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class SceneSnapshot:
    """Every body with a pose at one tick (for viewers and recordings)."""

    time_s: float
    tick: int
    bodies: tuple[BodyPose, ...]
