"""Frozen dataclasses describing a world: arena, bodies, chargers, robots and their devices.

Conventions: SI units (metres, seconds, kilograms, watts, joules); angles in radians; colours
as 0xRRGGBB integers. The arena is centred on the origin: x in [-size_x/2, size_x/2], y
likewise. Robot-relative poses use Player's frame: x forward, y left, yaw anticlockwise from x.
A robot's origin is the centre of its drive axle; its body box may be offset from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NamedTuple

from worlds.params import REQUIRED, param

__all__ = [
    "DEVICE_NAMES",
    "FIDELITIES",
    "ArenaSpec",
    "BlobfinderSpec",
    "BodySpec",
    "BoxSpec",
    "BumperSegment",
    "BumperSpec",
    "CameraSpec",
    "ChargerSpec",
    "DeviceSet",
    "Fidelity",
    "FiducialSpec",
    "GripperSpec",
    "LaserSpec",
    "MarkerSpec",
    "Mount",
    "ObjectSpec",
    "ObstacleSpec",
    "OverheadCameraSpec",
    "Pose",
    "Position2dSpec",
    "PowerSpec",
    "PtzSpec",
    "RangerSpec",
    "RobotSpec",
    "ScanSpec",
    "SimSpec",
    "SonarSpec",
    "WorldSpec",
]
"""What `worlds` re-exports."""

Fidelity = Literal["fast", "render"]
FIDELITIES: tuple[str, ...] = ("fast", "render")


class Pose(NamedTuple):
    """A planar pose: metres and radians."""

    x: float
    y: float
    yaw: float


class Mount(NamedTuple):
    """Where a sensor sits on its robot: metres forward, left and up, yaw in radians."""

    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class ObstacleSpec:
    """A static obstacle: an upright box (size_x by size_y), cylinder (radius) or polygon
    prism.

    A polygon's `points` are its vertices in the obstacle's frame (the pose turns and moves
    them), a simple polygon, convex or not (`worlds.polygon.problem` is None); its size is
    the extent of its points along the frame's axes (for whoever needs only a bound), and
    it stands from `base_m` up to `base_m + height_m`. Boxes and cylinders stand on the floor
    and have no points.
    """

    name: str
    pose: Pose
    shape: Literal["box", "cylinder", "polygon"]
    size_x_m: float
    size_y_m: float
    height_m: float
    colour: int
    points: tuple[tuple[float, float], ...] = ()
    base_m: float = 0.0

    @property
    def radius_m(self) -> float:
        return self.size_x_m / 2.0

    @property
    def top_m(self) -> float:
        return self.base_m + self.height_m

    def placed(self, points: tuple[tuple[float, float], ...] | None = None
               ) -> tuple[tuple[float, float], ...]:
        """World coordinates of `points` given in the obstacle's frame (its own points)."""
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        return tuple((x + c * px - s * py, y + s * px + c * py)
                     for px, py in (self.points if points is None else points))

    @staticmethod
    def polygon(name: str, pose: Pose, points: tuple[tuple[float, float], ...],
                height_m: float, colour: int, base_m: float = 0.0) -> ObstacleSpec:
        """A polygon prism; its size is the extent of its points."""
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        return ObstacleSpec(name, pose, "polygon", max(xs) - min(xs), max(ys) - min(ys),
                            height_m, colour, tuple((float(a), float(b)) for a, b in points),
                            base_m)


@dataclass(frozen=True)
class ArenaSpec:
    """The room: a rectangle of walls around the origin plus static obstacles."""

    size_x_m: float
    size_y_m: float
    wall_thickness_m: float
    wall_height_m: float
    wall_colour: int
    floor_colour: int
    obstacles: tuple[ObstacleSpec, ...] = ()

    @property
    def half_x_m(self) -> float:
        return self.size_x_m / 2.0

    @property
    def half_y_m(self) -> float:
        return self.size_y_m / 2.0


@dataclass(frozen=True)
class BoxSpec:
    """A movable box (pushed through contact physics)."""

    name: str
    pose: Pose
    size_x_m: float
    size_y_m: float
    size_z_m: float
    mass_kg: float
    colour: int
    friction: float = 0.5


@dataclass(frozen=True)
class ObjectSpec:
    """A small movable coloured cylinder; grippable when it fits the gripper."""

    name: str
    pose: Pose
    radius_m: float
    height_m: float
    mass_kg: float
    colour: int
    fiducial_id: int = 0


@dataclass(frozen=True)
class MarkerSpec:
    """A visual-only coloured post (e.g. a goal beacon): seen by cameras, not by rangers."""

    name: str
    x: float
    y: float
    radius_m: float
    height_m: float
    colour: int


@dataclass(frozen=True)
class ChargerSpec:
    """A charging pad on the floor: a robot whose origin is within radius_m charges at
    rate_w. A model with a footprint (size_x_m, size_y_m > 0, turned by yaw: a Stage model
    with `give_watts` / `take_watts`) is in contact with a robot whose body touches it
    instead (`player_server.sim.contact`); take_w is taken from a robot in contact."""

    name: str
    x: float
    y: float
    radius_m: float
    colour: int
    rate_w: float
    beacon_height_m: float = 0.5
    take_w: float = 0.0
    size_x_m: float = 0.0
    size_y_m: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class OverheadCameraSpec:
    """A ceiling camera looking straight down, reporting coloured things and robots."""

    name: str
    x: float
    y: float
    height_m: float
    view_size_x_m: float
    view_size_y_m: float
    width_px: int
    height_px: int
    position_noise_m: float = 0.0


@dataclass(frozen=True)
class SimSpec:
    """Simulation settings (Stage-style names)."""

    interval_sim_s: float = 0.1
    speedup: float = 1.0
    quit_time_s: float = 0.0
    seed: int = 0
    fidelity: Fidelity = "fast"
    physics_substeps: int = 2


@dataclass(frozen=True)
class BodySpec:
    """A robot's body box, relative to the robot origin (Pioneer 2-DX by default).

    `outline` (optional): the body's footprint as a convex polygon, anticlockwise, in the
    box's frame (x forward from the box's centre, y left), inside the box; the body is then
    that prism, as tall as the box, and the box only bounds it. Empty: the body is the box.
    """

    length_m: float = 0.445
    width_m: float = 0.40
    height_m: float = 0.30
    offset_x_m: float = -0.04
    mass_kg: float = 9.0
    outline: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class Position2dSpec:
    """Differential drive limits and odometry noise (fractions of distance / angle moved)."""

    max_speed_mps: float = param(0.5, "top speed (m/s)", positive=True)
    max_yaw_rate_radps: float = param(math.radians(100.0), "top turn rate (per s)",
                                      kind="angle", min=1e-6)
    accel_mps2: float = param(0.5, "acceleration (m/s^2)", positive=True)
    yaw_accel_radps2: float = param(math.radians(200.0), "turn acceleration (per s^2)",
                                    kind="angle", min=1e-6)
    odom_noise_fraction: float = param(0.0, "odometry noise, a fraction of the distance moved",
                                       key="odom_noise", min=0.0, max=1.0)
    odom_yaw_noise_fraction: float = param(0.0, "odometry noise, a fraction of the angle turned",
                                           key="odom_yaw_noise", min=0.0, max=1.0)


@dataclass(frozen=True)
class SonarSpec:
    """A ring of sonar transducers; each reports the nearest range within its cone."""

    poses: tuple[Mount, ...]
    min_range_m: float = 0.1
    max_range_m: float = 5.0
    cone_rad: float = math.radians(15.0)
    rays_per_transducer: int = 1


@dataclass(frozen=True)
class ScanSpec:
    """Geometry of a planar scanning range finder: readings evenly spaced over an arc."""

    pose: Mount
    min_angle_rad: float = -math.pi / 2
    max_angle_rad: float = math.pi / 2
    samples: int = 181
    min_range_m: float = 0.0
    max_range_m: float = 8.0
    range_res_m: float = 0.001
    frequency_hz: float = 10.0

    @property
    def resolution_rad(self) -> float:
        if self.samples < 2:
            return 0.0
        return (self.max_angle_rad - self.min_angle_rad) / (self.samples - 1)

    def angles_rad(self) -> tuple[float, ...]:
        return tuple(
            self.min_angle_rad + i * self.resolution_rad for i in range(self.samples)
        )


@dataclass(frozen=True)
class LaserSpec(ScanSpec):
    """A scanning laser (SICK LMS200 by default: 181 readings over 180 deg, 8 m)."""


@dataclass(frozen=True)
class RangerSpec(ScanSpec):
    """A generic scanning ranger (Player ranger interface); same geometry as a laser."""


@dataclass(frozen=True)
class CameraSpec:
    """A forward colour camera (pinhole): horizontal field of view and resolution."""

    pose: Mount
    tilt_rad: float = 0.0
    fov_h_rad: float = math.radians(60.0)
    width_px: int = 160
    height_px: int = 120
    max_range_m: float = 8.0

    @property
    def fov_v_rad(self) -> float:
        return 2.0 * math.atan(math.tan(self.fov_h_rad / 2.0) * self.height_px / self.width_px)

    @property
    def focal_px(self) -> float:
        return (self.width_px / 2.0) / math.tan(self.fov_h_rad / 2.0)


@dataclass(frozen=True)
class BlobfinderSpec:
    """Colour channels tracked by the blobfinder (uses the robot's camera geometry)."""

    channels: tuple[int, ...]
    min_area_px: int = 4
    colour_tolerance: int = 60


@dataclass(frozen=True)
class BumperSegment:
    """One bumper panel: midpoint and outward normal yaw relative to the robot, and length."""

    x: float
    y: float
    yaw: float
    length_m: float
    radius_m: float = 0.0


@dataclass(frozen=True)
class BumperSpec:
    segments: tuple[BumperSegment, ...]


@dataclass(frozen=True)
class GripperSpec:
    """Pioneer paddle gripper: paddles at pose.x ahead of the origin, opening width_m."""

    pose: Mount = param(REQUIRED, "where the paddles sit (default: a Pioneer's)", kind="mount")
    width_m: float = param(0.2, "opening between the paddles (m)", positive=True)
    depth_m: float = param(0.12, "depth of the paddles (m)", positive=True)
    max_object_radius_m: float = param(0.09, "the largest object radius it holds (m)",
                                       positive=True)
    capacity: int = param(1, "objects it can store", kind="integer", min=1)
    move_time_s: float = param(1.0, "time to open or close (s)", min=0.0)


@dataclass(frozen=True)
class PtzSpec:
    """Pan-tilt-zoom camera head (Sony EVI-D30 limits); zoom is the horizontal FOV."""

    pan_min_rad: float = param(math.radians(-100.0), "pan limit", kind="angle")
    pan_max_rad: float = param(math.radians(100.0), "pan limit", kind="angle")
    tilt_min_rad: float = param(math.radians(-25.0), "tilt limit", kind="angle")
    tilt_max_rad: float = param(math.radians(25.0), "tilt limit", kind="angle")
    zoom_min_rad: float = param(math.radians(4.4), "narrowest field of view", kind="angle",
                                min=1e-3)
    zoom_max_rad: float = param(math.radians(60.0), "widest field of view", kind="angle",
                                max=math.radians(170.0))
    pan_speed_radps: float = param(math.radians(80.0), "pan speed (per s)", kind="angle",
                                   min=1e-6)
    tilt_speed_radps: float = param(math.radians(50.0), "tilt speed (per s)", kind="angle",
                                    min=1e-6)
    zoom_speed_radps: float = param(math.radians(30.0), "zoom speed (per s)", kind="angle",
                                    min=1e-6)


@dataclass(frozen=True)
class PowerSpec:
    """Battery: capacity and draws. Volts map linearly from volts_empty to volts_full.

    Draw (W) = idle_w + moving_w * (|v|/vmax + |w|/wmax)/2 (up to 1) + sensor_w.
    At or below flat_fraction of capacity the motors stop until resume_fraction is regained.
    """

    capacity_j: float = param(180_000.0, "capacity (J)", positive=True)
    initial_fraction: float = param(1.0, "charge at the start", min=0.0, max=1.0)
    volts_full: float = param(13.0, "volts when full", positive=True)
    volts_empty: float = param(10.5, "volts when empty (< volts_full)", min=0.0)
    idle_w: float = param(10.0, "draw at rest (W)", key="idle_draw", min=0.0)
    moving_w: float = param(20.0, "draw at full drive (W)", key="moving_draw", min=0.0)
    sensor_w: float = param(5.0, "draw of the sensors (W; default: the sum of the robot's "
                            "devices' draws)", key="sensor_draw", min=0.0)
    flat_fraction: float = param(0.0, "at or below it the motors stop", min=0.0, max=1.0)
    resume_fraction: float = param(0.05, "the motors run again from it (>= flat_fraction)",
                                   min=0.0, max=1.0)


@dataclass(frozen=True)
class FiducialSpec:
    """Fiducial detector (e.g. a laser beacon reader): sees fiducial ids within a fan."""

    pose: Mount = param(REQUIRED, "where it sits (default: a Pioneer's laser)", kind="mount")
    min_range_m: float = param(0.0, "shortest range seen (m)", min=0.0)
    max_range_m: float = param(5.0, "longest range seen (m)", positive=True)
    fov_rad: float = param(math.pi, "width of its fan", kind="angle", min=1e-3,
                           max=2 * math.pi)


@dataclass(frozen=True)
class DeviceSet:
    """A robot's devices; None when absent."""

    position2d: Position2dSpec | None = None
    sonar: SonarSpec | None = None
    laser: LaserSpec | None = None
    ranger: RangerSpec | None = None
    camera: CameraSpec | None = None
    blobfinder: BlobfinderSpec | None = None
    bumper: BumperSpec | None = None
    gripper: GripperSpec | None = None
    ptz: PtzSpec | None = None
    power: PowerSpec | None = None
    fiducial: FiducialSpec | None = None
    extra: tuple[tuple[str, Any], ...] = ()
    """Devices of the kinds declared in `worlds.devices`: (name, spec), in their order."""

    def names(self) -> tuple[str, ...]:
        """Names of the devices present, in declaration order (built-ins, then the others)."""
        return tuple(n for n in DEVICE_NAMES if getattr(self, n) is not None) + tuple(
            n for n, _ in self.extra)

    def get(self, name: str) -> Any:
        """The spec of the device `name`, None when the robot has none."""
        if name in DEVICE_NAMES:
            return getattr(self, name)
        return next((spec for n, spec in self.extra if n == name), None)


DEVICE_NAMES: tuple[str, ...] = (
    "position2d",
    "sonar",
    "laser",
    "ranger",
    "camera",
    "blobfinder",
    "bumper",
    "gripper",
    "ptz",
    "power",
    "fiducial",
)


@dataclass(frozen=True)
class RobotSpec:
    name: str
    pose: Pose
    colour: int
    body: BodySpec
    devices: DeviceSet
    fiducial_id: int = 0

    @property
    def mobile(self) -> bool:
        return self.devices.position2d is not None


@dataclass(frozen=True)
class WorldSpec:
    name: str
    source: Path
    arena: ArenaSpec
    sim: SimSpec
    robots: tuple[RobotSpec, ...]
    boxes: tuple[BoxSpec, ...] = ()
    objects: tuple[ObjectSpec, ...] = ()
    markers: tuple[MarkerSpec, ...] = ()
    chargers: tuple[ChargerSpec, ...] = ()
    overhead_camera: OverheadCameraSpec | None = None
    description: str = ""

    def robot(self, name: str) -> RobotSpec:
        for r in self.robots:
            if r.name == name:
                return r
        raise KeyError(f"world {self.name!r} has no robot {name!r}")

    def robot_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.robots)
