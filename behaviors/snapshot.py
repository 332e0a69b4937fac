"""Frozen sensor snapshots: everything a behaviour may look at during one tick.

A snapshot is built once per data round from the Player proxies (see `behaviors.sensing`) and
then shared, read-only, by every behaviour thread. Each reading keeps the simulation time of
the data it came from, so behaviours can ignore stale data (`Snapshot.fresh`). Readings are
``None`` when the robot has no such device or no data has arrived yet.

Conventions: metres, radians, seconds (simulation time); robot frame x forward, y left;
bearings are counter-clockwise positive (a blob on the right has a negative bearing).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from player_server.frozen import frozen_constructor

# per-tick readings are built every data round without the frozen __init__
slot_maker = frozen_constructor


@dataclass(frozen=True, slots=True)
class Pose2D:
    x_m: float
    y_m: float
    yaw_rad: float

    def distance_to(self, x_m: float, y_m: float) -> float:
        return math.hypot(x_m - self.x_m, y_m - self.y_m)

    def bearing_to(self, x_m: float, y_m: float) -> float:
        """Bearing of a world point in the robot frame, in (-pi, pi]."""
        return wrap_angle(math.atan2(y_m - self.y_m, x_m - self.x_m) - self.yaw_rad)


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    wrapped = math.fmod(angle_rad + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


@dataclass(frozen=True, slots=True)
class Odometry:
    pose: Pose2D
    vx_mps: float
    vyaw_radps: float
    stall: bool
    time_s: float


@dataclass(frozen=True, slots=True)
class RangeScan:
    """A planar range scan (sonar ring or laser): one bearing per range, robot frame.

    `origin_x_m` is the sensor's forward offset (sonar bearings already include each
    transducer's yaw; ranges are measured from each transducer's position, approximated by
    `offsets_m`, the distance of each transducer from the robot centre).
    """

    ranges_m: tuple[float, ...]
    bearings_rad: tuple[float, ...]
    max_range_m: float
    time_s: float
    offsets_m: tuple[float, ...] = ()
    scan_id: int = 0

    def min_in_sector(self, low_rad: float, high_rad: float) -> float:
        """Smallest range (from the robot centre) whose bearing lies in [low, high]."""
        best = math.inf
        offsets = self.offsets_m
        for i, bearing in enumerate(self.bearings_rad):
            if low_rad <= bearing <= high_rad:
                r = self.ranges_m[i]
                if r <= 0.0:
                    continue
                if offsets:
                    r += offsets[i]
                if r < best:
                    best = r
        return best


@dataclass(frozen=True, slots=True)
class Blob:
    colour: int  # 0xRRGGBB
    area_px: int
    x_px: float
    y_px: float
    left_px: int
    right_px: int
    top_px: int
    bottom_px: int
    range_m: float


@dataclass(frozen=True, slots=True)
class BlobView:
    """Blobs seen by a (robot or overhead) camera; `fov_rad` is the horizontal field of view."""

    width_px: int
    height_px: int
    blobs: tuple[Blob, ...]
    fov_rad: float
    time_s: float

    def bearing_of_px(self, x_px: float) -> float:
        """Bearing in the robot frame of an image column (counter-clockwise positive)."""
        if self.width_px <= 0:
            return 0.0
        half = self.width_px / 2.0
        return -((x_px - half) / half) * (self.fov_rad / 2.0)

    def largest(self, colour: int) -> Blob | None:
        best: Blob | None = None
        for blob in self.blobs:
            if blob.colour == colour and (best is None or blob.area_px > best.area_px):
                best = blob
        return best


@dataclass(frozen=True, slots=True)
class Bumpers:
    """Bumper panels; `front` marks the panels on the front of the robot (all if empty)."""

    pressed: tuple[bool, ...]
    time_s: float
    front: tuple[bool, ...] = ()

    @property
    def any_pressed(self) -> bool:
        return any(self.pressed)

    @property
    def front_pressed(self) -> bool:
        if len(self.front) != len(self.pressed):
            return any(self.pressed)
        return any(p and f for p, f in zip(self.pressed, self.front, strict=True))


@dataclass(frozen=True, slots=True)
class Power:
    percent: float
    volts: float
    charging: int  # 1 receiving charge, -1 supplying, 0 neither
    time_s: float


@dataclass(frozen=True, slots=True)
class Gripper:
    state: int  # 1 open, 2 closed, 3 moving, 4 error
    beams: int
    stored: int
    time_s: float


@dataclass(frozen=True, slots=True)
class Mark:
    """What the robot saw when the current task stage began (for relative manoeuvres)."""

    time_s: float
    pose: Pose2D | None
    laser: RangeScan | None


@dataclass(frozen=True, slots=True)
class Snapshot:
    """One tick's view of the robot. Frozen; replaced every tick, never mutated."""

    time_s: float
    odometry: Odometry | None = None
    sonar: RangeScan | None = None
    laser: RangeScan | None = None
    camera: BlobView | None = None
    bumpers: Bumpers | None = None
    power: Power | None = None
    gripper: Gripper | None = None
    mark: Mark | None = field(default=None)

    @property
    def pose(self) -> Pose2D | None:
        return None if self.odometry is None else self.odometry.pose

    def with_mark(self, mark: Mark | None) -> Snapshot:
        return replace(self, mark=mark)

    @staticmethod
    def fresh(reading_time_s: float, now_s: float, max_age_s: float) -> bool:
        """True when a reading stamped `reading_time_s` is at most `max_age_s` old at `now_s`."""
        return now_s - reading_time_s <= max_age_s


class Deferred:
    """A reading not built yet: `get()` builds it once from values captured beforehand."""

    __slots__ = ("_args", "_build", "_value")

    def __init__(self, build: Callable[..., Any], *args: Any) -> None:
        self._build = build
        self._args = args
        self._value: Any = Deferred

    def get(self) -> Any:
        value = self._value
        if value is Deferred:
            value = self._value = self._build(*self._args)
        return value


_SLOTS = {name: Snapshot.__dict__[name] for name in
          ("odometry", "sonar", "laser", "camera", "bumpers", "power", "gripper")}


def _lazy_reading(name: str) -> property:
    slot = _SLOTS[name]
    get_slot, set_slot = slot.__get__, slot.__set__

    def read(self: Snapshot) -> Any:
        value = get_slot(self)
        if type(value) is Deferred:
            value = value.get()
            set_slot(self, value)
        return value

    def store(self: Snapshot, value: Any) -> None:  # for __init__ (replace) only
        set_slot(self, value)

    return property(read, store, doc=f"the {name} reading (built when first read)")


class LazySnapshot(Snapshot):
    """A `Snapshot` whose readings may be `Deferred`: built by the first thread to read them.

    A deferred reading is built from values captured when the snapshot was made (never
    from live proxies), so it is the same whenever and wherever it is read; readings no
    behaviour looks at are never built. Equal to (and hashed like) the plain `Snapshot`
    with the same readings; frozen like it.
    """

    __slots__ = ()

    odometry = _lazy_reading("odometry")
    sonar = _lazy_reading("sonar")
    laser = _lazy_reading("laser")
    camera = _lazy_reading("camera")
    bumpers = _lazy_reading("bumpers")
    power = _lazy_reading("power")
    gripper = _lazy_reading("gripper")

    def _fields(self) -> tuple[Any, ...]:
        return (self.time_s, self.odometry, self.sonar, self.laser, self.camera, self.bumpers,
                self.power, self.gripper, self.mark)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Snapshot):
            return NotImplemented
        return self._fields() == (other.time_s, other.odometry, other.sonar, other.laser,
                                  other.camera, other.bumpers, other.power, other.gripper,
                                  other.mark)

    def __hash__(self) -> int:
        return hash(self._fields())

    def with_mark(self, mark: Mark | None) -> Snapshot:
        slots = _SLOTS
        return make_lazy_snapshot(
            self.time_s, slots["odometry"].__get__(self), slots["sonar"].__get__(self),
            slots["laser"].__get__(self), slots["camera"].__get__(self),
            slots["bumpers"].__get__(self), slots["power"].__get__(self),
            slots["gripper"].__get__(self), mark)


EMPTY = Snapshot(time_s=0.0)

make_pose = slot_maker(Pose2D)
make_odometry = slot_maker(Odometry)
make_scan = slot_maker(RangeScan)
make_blob = slot_maker(Blob)
make_blob_view = slot_maker(BlobView)
make_bumpers = slot_maker(Bumpers)
make_power = slot_maker(Power)
make_gripper = slot_maker(Gripper)
make_snapshot = slot_maker(Snapshot)
#: the same fields, in order; any reading may be a `Deferred`
make_lazy_snapshot = slot_maker(LazySnapshot)
