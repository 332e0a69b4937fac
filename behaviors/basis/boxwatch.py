"""The watcher's senses: the box's alignment from the laser, the goal from the camera."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.basis.colour import ColourFollower
from behaviors.basis.speed_limits import ForwardSpeedLimit
from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import Blob, BlobView, RangeScan, Snapshot, wrap_angle


@dataclass(frozen=True, slots=True)
class Face:
    """A straight face seen by the laser, in the robot frame."""

    range_m: float  # to the face's closest reading
    bearing_rad: float  # of the face's centre
    normal_rad: float  # direction of the face normal, pointing away from the robot
    width_m: float
    points: int


def find_face(
    scan: RangeScan, centre_rad: float, half_width_rad: float, max_range_m: float,
    jump_m: float = 0.15,
) -> Face | None:
    """Fit a line to the contiguous cluster around the nearest reading in a sector.

    Returns None when fewer than three readings form the cluster.
    """
    ranges = scan.ranges_m
    bearings = scan.bearings_rad
    n = len(ranges)
    nearest_i = -1
    nearest_r = max_range_m
    for i in range(n):
        r = ranges[i]
        if 0.0 < r < nearest_r and abs(wrap_angle(bearings[i] - centre_rad)) <= half_width_rad:
            nearest_r = r
            nearest_i = i
    if nearest_i < 0:
        return None
    lo = nearest_i
    while lo > 0 and abs(ranges[lo - 1] - ranges[lo]) < jump_m and ranges[lo - 1] < max_range_m:
        lo -= 1
    hi = nearest_i
    while hi < n - 1 and abs(ranges[hi + 1] - ranges[hi]) < jump_m and ranges[hi + 1] < max_range_m:
        hi += 1
    count = hi - lo + 1
    if count < 3:
        return None
    sx = sy = 0.0
    for i in range(lo, hi + 1):
        sx += ranges[i] * math.cos(bearings[i])
        sy += ranges[i] * math.sin(bearings[i])
    mx, my = sx / count, sy / count
    sxx = syy = sxy = 0.0
    for i in range(lo, hi + 1):
        dx = ranges[i] * math.cos(bearings[i]) - mx
        dy = ranges[i] * math.sin(bearings[i]) - my
        sxx += dx * dx
        syy += dy * dy
        sxy += dx * dy
    # Principal direction of the points = the face direction; the normal is perpendicular.
    direction = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
    normal = direction + math.pi / 2.0
    # Point the normal away from the robot (same side as the centroid).
    if math.cos(normal) * mx + math.sin(normal) * my < 0.0:
        normal += math.pi
    first_x = ranges[lo] * math.cos(bearings[lo])
    first_y = ranges[lo] * math.sin(bearings[lo])
    last_x = ranges[hi] * math.cos(bearings[hi])
    last_y = ranges[hi] * math.sin(bearings[hi])
    width = math.hypot(last_x - first_x, last_y - first_y)
    return Face(nearest_r, math.atan2(my, mx), wrap_angle(normal), width, count)


@dataclass(frozen=True, slots=True)
class BoxAlignmentFromLaser:
    """Find the box face in the laser sector centred on `centre_rad`; report its tilt.

    Signal "box" with value = the tilt of the face: the angle from the line of sight to the
    face normal (positive = counter-clockwise), so 0 means the robot looks square at the
    face. It only observes, except that it asks the robot to wait (stand still) while the
    box is farther than `wait_range_m`, so a watcher leading the box does not run away.
    With `look_for` (a colour, the goal's), it waits turning in place at `look_turn_radps`
    while that colour is out of view, so a goal that moved or changed is found again.
    """

    centre_rad: float = 0.0
    half_width_rad: float = math.radians(45.0)
    max_range_m: float = 3.0
    min_width_m: float = 0.2
    wait_range_m: float = math.inf
    max_age_s: float = 0.5
    look_for: int | None = None
    look_turn_radps: float = 0.4
    name: str = "box-alignment-from-laser"
    max_speed_mps: float = 0.0
    max_turn_radps: float = 0.0

    def face(self, snapshot: Snapshot, now: float) -> Face | None:
        laser = snapshot.laser
        if laser is None or now - laser.time_s > self.max_age_s or not laser.ranges_m:
            return None
        face = find_face(laser, self.centre_rad, self.half_width_rad, self.max_range_m)
        if face is None or face.width_m < self.min_width_m:
            return None
        return face

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        face = self.face(snapshot, now)
        if face is None:
            return INACTIVE
        tilt = wrap_angle(face.normal_rad - face.bearing_rad)
        if face.range_m > self.wait_range_m:
            turn = 0.0
            if self.look_for is not None:
                view = snapshot.camera
                if view is not None and view.largest(self.look_for) is None:
                    turn = self.look_turn_radps
            return Proposal(True, 0.0, turn, 1.0, "box", tilt)
        return Proposal(False, 0.0, 0.0, 0.0, "box", tilt)


@dataclass(frozen=True, slots=True)
class GoalFromCamera(ForwardSpeedLimit, ColourFollower):
    """Steer towards the goal marker (a colour blob); signal "goal" with its bearing."""

    colour: int
    speed_mps: float = 0.2
    max_turn_radps: float = 0.6
    turn_gain: float = 1.5
    arrive_range_m: float = 0.8
    max_age_s: float = 0.5
    weight: float = 0.5
    name: str = "goal-from-camera"

    def follow(self, view: BlobView, blob: Blob) -> Proposal:
        bearing, turn = self.steer(view, blob.x_px)
        if blob.range_m <= self.arrive_range_m:
            return Proposal(True, 0.0, turn, self.weight, "goal-reached", bearing)
        speed = self.speed_mps * max(0.0, math.cos(bearing))
        return Proposal(True, speed, turn, self.weight, "goal", bearing)
