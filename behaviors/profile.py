"""What a robot knows about itself and its surroundings, independent of any task."""

from __future__ import annotations

import math
from dataclasses import dataclass

# Subjects derived from devices (MURDOCH resource subjects).
DEVICE_SUBJECTS: dict[str, str] = {
    "position2d": "mobile",
    "sonar": "sonar",
    "laser": "laser",
    "ranger": "laser",
    "blobfinder": "camera",
    "camera": "camera",
    "bumper": "bumper",
    "gripper": "gripper",
    "ptz": "ptz",
    "power": "power",
    "fiducial": "fiducial",
}
OVERHEAD_CAMERA = "overhead-camera"


def subjects_for(interfaces: frozenset[str] | set[str]) -> frozenset[str]:
    """Resource subjects of a robot with the given Player interface names.

    A camera on something that cannot move (no position2d) is an overhead camera.
    """
    subjects = {DEVICE_SUBJECTS[i] for i in interfaces if i in DEVICE_SUBJECTS}
    if "camera" in subjects and "mobile" not in subjects:
        subjects.discard("camera")
        subjects.add(OVERHEAD_CAMERA)
    return frozenset(subjects)


@dataclass(frozen=True, slots=True)
class Charger:
    name: str
    x_m: float
    y_m: float
    radius_m: float


@dataclass(frozen=True, slots=True)
class OverheadView:
    """Where an overhead camera looks: its centre and footprint on the floor."""

    x_m: float
    y_m: float
    view_size_x_m: float
    view_size_y_m: float

    def to_world(self, x_px: float, y_px: float, width_px: int, height_px: int) -> tuple[
        float, float
    ]:
        """Image (column, row) to floor (x, y): columns run along +x, rows along -y."""
        if width_px <= 0 or height_px <= 0:
            return (math.nan, math.nan)
        wx = self.x_m + (x_px / width_px - 0.5) * self.view_size_x_m
        wy = self.y_m - (y_px / height_px - 0.5) * self.view_size_y_m
        return (wx, wy)


@dataclass(frozen=True, slots=True)
class RobotProfile:
    name: str
    subjects: frozenset[str]
    max_speed_mps: float = 0.5
    max_turn_radps: float = 1.5
    camera_fov_rad: float = math.radians(60.0)
    chargers: tuple[Charger, ...] = ()
    overhead: OverheadView | None = None
    seed: int = 0
    landmarks: tuple[tuple[int, float, float], ...] = ()
    """(colour, x, y) of the coloured objects and boxes where the world file puts them."""
    bid_terms: tuple[str, ...] = ()
    """Optional terms added to every task's metric (`behaviors.library.BID_TERMS`)."""

    def has(self, *subjects: str) -> bool:
        return all(s in self.subjects for s in subjects)

    def nearest_charger(self, x_m: float, y_m: float) -> Charger | None:
        best: Charger | None = None
        best_d = math.inf
        for c in self.chargers:
            d = math.hypot(c.x_m - x_m, c.y_m - y_m)
            if d < best_d:
                best, best_d = c, d
        return best
