"""Camera (blobfinder) behaviours: visual servo to a colour, keep a distance to a colour."""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviors.basis.speed_limits import ForwardSpeedLimit
from behaviors.proposal import INACTIVE, Proposal, clamp
from behaviors.snapshot import Blob, BlobView, Snapshot


def aim_px(blob: Blob, fraction: float, width_px: int = 0) -> float:
    """Image column at `fraction` of a blob's width (0 = left edge, 0.5 = centre, 1 = right).

    A blob cut by an image edge continues beyond it: aiming at the end on that side means
    aiming at the image edge (turn towards it). A blob cut by both edges (the robot is up
    against it) has no visible ends: aim straight ahead, at the image centre.
    """
    if width_px > 0:
        cut_left = blob.left_px <= 0
        cut_right = blob.right_px >= width_px - 1
        if cut_left and cut_right:
            return width_px / 2.0
        if cut_right and fraction > 0.5:
            return float(width_px - 1)
        if cut_left and fraction < 0.5:
            return 0.0
    return blob.left_px + fraction * (blob.right_px - blob.left_px)


def end_px(blob: Blob, fraction: float, width_px: int) -> float | None:
    """Image column of the blob's end nearer `fraction` (None if that end is out of view)."""
    if fraction < 0.5:
        return None if blob.left_px <= 0 else float(blob.left_px)
    if fraction > 0.5:
        return None if blob.right_px >= width_px - 1 else float(blob.right_px)
    if blob.left_px <= 0 or blob.right_px >= width_px - 1:
        return None
    return (blob.left_px + blob.right_px) / 2.0


def fresh_view(view: BlobView | None, now: float, max_age_s: float) -> BlobView | None:
    """The camera view if it is at most `max_age_s` old at `now`, else None."""
    if view is None or now - view.time_s > max_age_s:
        return None
    return view


def sighting(view: BlobView | None, now: float, max_age_s: float,
             colour: int) -> tuple[BlobView, Blob] | None:
    """A fresh view and its largest blob of `colour` (None when stale or not in view)."""
    view = fresh_view(view, now, max_age_s)
    blob = None if view is None else view.largest(colour)
    return None if view is None or blob is None else (view, blob)


def steer_at(view: BlobView, px: float, turn_gain: float,
             max_turn_radps: float) -> tuple[float, float]:
    """The bearing of image column `px` and the turn rate towards it (gain, then limit)."""
    bearing = view.bearing_of_px(px)
    return bearing, clamp(turn_gain * bearing, max_turn_radps)


class ColourFollower:
    """Follows the largest blob of `colour` in a camera view at most `max_age_s` old, steering
    at it with `turn_gain` up to `max_turn_radps`.

    Inactive without such a view and blob; with them, `follow` decides.
    """

    __slots__ = ()
    colour: int
    max_age_s: float
    turn_gain: float
    max_turn_radps: float

    def sight(self, snapshot: Snapshot, now: float) -> tuple[BlobView, Blob] | None:
        """The fresh camera view and its largest blob of the colour (None: stale or unseen)."""
        return sighting(snapshot.camera, now, self.max_age_s, self.colour)

    def steer(self, view: BlobView, px: float) -> tuple[float, float]:
        """The bearing of image column `px` and the turn rate towards it."""
        return steer_at(view, px, self.turn_gain, self.max_turn_radps)

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        sight = self.sight(snapshot, now)
        return INACTIVE if sight is None else self.follow(*sight)

    def follow(self, view: BlobView, blob: Blob) -> Proposal:
        """The proposal while `blob` is the largest of the colour in the fresh `view`."""
        raise NotImplementedError


class KeyedColourFollower(ColourFollower):
    """A colour follower whose proposal depends only on `sight_key` of the view and blob it
    follows, and is the same (inactive) whenever it follows none (see `runner`)."""

    __slots__ = ()

    def inputs_key(self, snapshot: Snapshot, now: float) -> object:
        """0 while no blob of the colour is in a fresh view, else `sight_key` of the two."""
        sight = self.sight(snapshot, now)
        return 0 if sight is None else self.sight_key(*sight)

    def sight_key(self, view: BlobView, blob: Blob) -> object:
        """All of `view` and `blob` that `follow` reads."""
        raise NotImplementedError


@dataclass(frozen=True, slots=True)
class VisualServoToColour(ForwardSpeedLimit, KeyedColourFollower):
    """Steer at a colour blob and drive towards it; "reached" within `stop_range_m`.

    `aim_fraction` picks the point across the blob to steer at, so a pusher can aim at the
    left end (0.2), the middle (0.5) or the right end (0.8) of a long box. Within the stop
    range it only turns, and says "reached" once the aim point is within
    `align_tolerance_rad` of straight ahead.
    """

    colour: int
    aim_fraction: float = 0.5
    speed_mps: float = 0.3
    stop_range_m: float = 0.0
    align_tolerance_rad: float = math.pi
    max_turn_radps: float = 0.8
    turn_gain: float = 2.0
    max_age_s: float = 0.5
    weight: float = 0.7
    name: str = "visual-servo-to-colour"

    def sight_key(self, view: BlobView, blob: Blob) -> object:
        return (blob, view.width_px, view.fov_rad)

    def follow(self, view: BlobView, blob: Blob) -> Proposal:
        bearing, turn = self.steer(view, aim_px(blob, self.aim_fraction, view.width_px))
        if blob.range_m <= self.stop_range_m:
            aligned = abs(bearing) <= self.align_tolerance_rad
            return Proposal(True, 0.0, turn, self.weight, "reached" if aligned else "seen",
                            blob.range_m)
        speed = self.speed_mps * max(0.0, math.cos(bearing))
        if abs(bearing) > math.radians(45.0):
            speed = 0.0
        return Proposal(True, speed, turn, self.weight, "seen", blob.range_m)


@dataclass(frozen=True, slots=True)
class KeepDistanceToColour(KeyedColourFollower):
    """Track a colour blob from a safe distance: face it and hold `distance_m` to it."""

    colour: int
    distance_m: float = 1.0
    tolerance_m: float = 0.15
    max_speed_mps: float = 0.3
    max_turn_radps: float = 0.8
    speed_gain: float = 0.8
    turn_gain: float = 2.0
    max_age_s: float = 0.5
    weight: float = 0.7
    name: str = "keep-distance-to-colour"

    def sight_key(self, view: BlobView, blob: Blob) -> object:
        return (blob.x_px, blob.range_m, view.width_px, view.fov_rad)

    def follow(self, view: BlobView, blob: Blob) -> Proposal:
        bearing, turn = self.steer(view, blob.x_px)
        error = blob.range_m - self.distance_m
        if not math.isfinite(error):
            return Proposal(True, 0.0, turn, self.weight, "tracking", 0.0)
        speed = 0.0 if abs(error) <= self.tolerance_m else clamp(
            self.speed_gain * error, self.max_speed_mps
        )
        if abs(bearing) > math.radians(45.0):
            speed = min(speed, 0.0)
        return Proposal(True, speed, turn, self.weight, "tracking", error)


@dataclass(frozen=True, slots=True)
class ViewOfEnd(ForwardSpeedLimit):
    """Get a view of one end of a colour blob (a long box) before approaching it.

    When that end is in view no more than `max_bearing_rad` off, raise "in-view" and stand
    still. Otherwise (e.g. it is the far end of the box, or the box fills the image) back
    straight away until the box is `min_range_m` away, then turn towards that end.
    `aim_fraction` 0.5 asks for both ends in view.
    """

    colour: int
    aim_fraction: float = 0.5
    min_range_m: float = 0.5
    max_bearing_rad: float = math.radians(25.0)
    speed_mps: float = 0.2
    max_turn_radps: float = 0.5
    max_age_s: float = 0.5
    weight: float = 0.7
    name: str = "view-of-end"

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        view = fresh_view(snapshot.camera, now, self.max_age_s)
        if view is None:
            return INACTIVE
        blob = view.largest(self.colour)
        if blob is None:
            # Too close to see it at all: back straight away.
            return Proposal(True, -self.speed_mps, 0.0, self.weight, "", 0.0)
        px = end_px(blob, self.aim_fraction, view.width_px)
        bearing = 0.0 if px is None else view.bearing_of_px(px)
        if px is not None and abs(bearing) <= self.max_bearing_rad:
            return Proposal(True, 0.0, 0.0, self.weight, "in-view", bearing)
        if blob.range_m < self.min_range_m or (px is None and self.aim_fraction == 0.5):
            # Get room first, backing straight, so the approach is not too oblique.
            return Proposal(True, -self.speed_mps, 0.0, self.weight, "", bearing)
        if px is None:
            # That end is beyond the image edge on its side: turn towards it.
            turn = self.max_turn_radps if self.aim_fraction < 0.5 else -self.max_turn_radps
            return Proposal(True, 0.0, turn, self.weight, "", 0.0)
        return Proposal(True, 0.0, clamp(2.0 * bearing, self.max_turn_radps), self.weight, "",
                        bearing)
