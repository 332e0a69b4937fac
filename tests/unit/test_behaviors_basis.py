"""What each basis behaviour does in small hand-made scenes."""

from __future__ import annotations

import math
import random

from behaviors import basis
from behaviors.basis.boxwatch import find_face
from behaviors.snapshot import (
    Blob,
    BlobView,
    Bumpers,
    Mark,
    Odometry,
    Pose2D,
    Power,
    RangeScan,
    Snapshot,
)

T = 10.0
RED = 0xFF0000
BEARINGS = tuple(-math.pi / 2 + i * math.pi / 180 for i in range(181))


def odo(x: float = 0.0, y: float = 0.0, yaw: float = 0.0, stall: bool = False) -> Odometry:
    return Odometry(Pose2D(x, y, yaw), 0.0, 0.0, stall, T)


def laser(ranges: list[float]) -> RangeScan:
    return RangeScan(tuple(ranges), BEARINGS, 8.0, T)


def view(*blobs: Blob) -> BlobView:
    return BlobView(160, 120, blobs, math.radians(60), T)


def blob(left: int, right: int, range_m: float = 2.0, colour: int = RED) -> Blob:
    return Blob(colour, (right - left) * 20, (left + right) / 2, 60, left, right, 50, 70, range_m)


def test_avoid_turns_away_from_obstacle_on_the_right() -> None:
    ranges = [5.0] * 181
    for i in range(60, 90):  # right of centre (negative bearings)
        ranges[i] = 0.3
    p = basis.AvoidWithLaser(safe_range_m=0.5).decide(Snapshot(T, laser=laser(ranges)), T)
    assert p.active and p.vyaw_radps > 0 and p.signal == "obstacle"
    clear = basis.AvoidWithLaser().decide(Snapshot(T, laser=laser([5.0] * 181)), T)
    assert not clear.active


def test_avoid_ignores_blind_cone() -> None:
    ranges = [5.0] * 181
    ranges[90] = 0.2  # straight ahead only
    b = basis.AvoidWithLaser(ignore_half_angle_rad=math.radians(10))
    assert not b.decide(Snapshot(T, laser=laser(ranges)), T).active


def test_avoid_inputs_key_is_false_exactly_when_it_would_stay_inactive() -> None:
    rng = random.Random(7)
    for case in range(300):
        b = basis.AvoidWithLaser(safe_range_m=0.5,
                                 ignore_half_angle_rad=math.radians(10) if case % 2 else 0.0)
        ranges = [rng.choice((5.0, rng.uniform(0.1, 1.0))) for _ in range(181)]
        age = rng.choice((0.0, 0.0, 1.0))  # a stale scan is ignored
        snap = Snapshot(T + age, laser=laser(ranges))
        key = b.inputs_key(snap, T + age)
        p = b.decide(snap, T + age)
        assert (key is False) == (not p.active), (case, key, p)
        assert key in (False, None)
    assert basis.AvoidWithLaser().inputs_key(Snapshot(T), T) is False  # no scan at all


def test_equal_inputs_keys_give_equal_proposals() -> None:
    """A behaviour's inputs_key, where it has one, stands for everything decide reads."""
    rng = random.Random(11)
    behaviours = (basis.VisualServoToColour(RED, aim_fraction=0.2, stop_range_m=1.0),
                  basis.KeepDistanceToColour(RED, 1.5), basis.PushWithBumpers())
    for b in behaviours:
        seen_keys: dict[object, object] = {}
        for _ in range(400):
            t = T + rng.choice((0.0, 1.0))  # scenes taken at T, one of them stale at T + 1
            left = rng.randrange(-20, 150)
            blobs = (blob(left, left + rng.randrange(1, 60), rng.choice((0.5, 1.0, 2.5))),
                     ) if rng.random() < 0.7 else ()
            snap = Snapshot(T, camera=view(*blobs), odometry=odo(stall=rng.random() < 0.3),
                            bumpers=Bumpers(tuple(rng.random() < 0.3 for _ in range(3)), T))
            key = b.inputs_key(snap, t)
            p = b.decide(snap, t)
            assert seen_keys.setdefault(key, p) == p, (b.name, key)


def test_servo_to_location_turns_towards_goal_and_stops_there() -> None:
    s = basis.ServoToLocation(0.0, 3.0)
    p = s.decide(Snapshot(T, odometry=odo()), T)
    assert p.vyaw_radps > 0 and p.vx_mps == 0.0  # goal at 90 deg left: turn in place
    ahead = s.decide(Snapshot(T, odometry=odo(yaw=math.pi / 2)), T)
    assert ahead.vx_mps > 0 and abs(ahead.vyaw_radps) < 1e-9
    there = s.decide(Snapshot(T, odometry=odo(0.0, 2.9)), T)
    assert there.signal == "at-goal" and there.vx_mps == 0.0


def test_wander_is_a_function_of_seed_and_time() -> None:
    a = basis.Wander(seed=1, straight_fraction=0.0)
    turns = {a.decide(Snapshot(0.0), t * 2.0 + 0.5).vyaw_radps for t in range(20)}
    assert len(turns) > 5
    b = basis.Wander(seed=2, straight_fraction=0.0)
    assert [a.decide(Snapshot(0.0), t).vyaw_radps for t in range(0, 40, 2)] != [
        b.decide(Snapshot(0.0), t).vyaw_radps for t in range(0, 40, 2)
    ]


def test_visual_servo_aims_at_the_chosen_end() -> None:
    centred = view(blob(40, 120))
    left = basis.VisualServoToColour(RED, aim_fraction=0.2).decide(Snapshot(T, camera=centred), T)
    right = basis.VisualServoToColour(RED, aim_fraction=0.8).decide(Snapshot(T, camera=centred), T)
    assert left.vyaw_radps > 0 > right.vyaw_radps
    near = basis.VisualServoToColour(RED, stop_range_m=1.0).decide(
        Snapshot(T, camera=view(blob(70, 90, range_m=0.8))), T
    )
    assert near.signal == "reached" and near.vx_mps == 0.0
    off_axis = basis.VisualServoToColour(RED, stop_range_m=1.0, align_tolerance_rad=0.1).decide(
        Snapshot(T, camera=view(blob(10, 30, range_m=0.8))), T
    )
    assert off_axis.signal == "seen" and off_axis.vx_mps == 0.0 and off_axis.vyaw_radps > 0
    # Up against a long box (cut by both image edges) there is no end to aim at: go straight.
    against = basis.VisualServoToColour(RED, aim_fraction=0.2).decide(
        Snapshot(T, camera=view(blob(0, 159, range_m=0.05))), T
    )
    assert against.vyaw_radps == 0.0
    # Cut by the right edge only: the right end is beyond it, so turn right to reach it.
    cut = view(blob(60, 159))
    to_right = basis.VisualServoToColour(RED, aim_fraction=0.8).decide(Snapshot(T, camera=cut), T)
    assert to_right.vyaw_radps < 0
    unseen = basis.VisualServoToColour(0x00FF00).decide(Snapshot(T, camera=centred), T)
    assert not unseen.active


def test_keep_distance_backs_off_when_too_close() -> None:
    b = basis.KeepDistanceToColour(RED, distance_m=1.5)
    close = b.decide(Snapshot(T, camera=view(blob(70, 90, range_m=0.5))), T)
    far = b.decide(Snapshot(T, camera=view(blob(70, 90, range_m=3.0))), T)
    assert close.vx_mps < 0 < far.vx_mps


def test_push_with_bumpers_only_on_contact_and_blocked_when_stalled() -> None:
    b = basis.PushWithBumpers()
    assert not b.decide(Snapshot(T, bumpers=Bumpers((False,) * 5, T)), T).active
    pressed = Bumpers((False, True, False), T)
    assert b.decide(Snapshot(T, bumpers=pressed, odometry=odo()), T).signal == "contact"
    assert b.decide(Snapshot(T, bumpers=pressed, odometry=odo(stall=True)), T).signal == "blocked"


def test_watch_for_motion_compares_with_the_stage_start_scan() -> None:
    reference = laser([4.0] * 181)
    quiet = Snapshot(T, laser=laser([4.0] * 181), mark=Mark(0.0, None, reference))
    w = basis.WatchForMotionWithLaser()
    assert w.decide(quiet, T).signal == ""
    changed = [4.0] * 181
    for i in range(80, 86):
        changed[i] = 1.5
    alarm = w.decide(Snapshot(T, laser=laser(changed), mark=Mark(0.0, None, reference)), T)
    assert alarm.signal == "motion" and alarm.value == 6.0 and alarm.vx_mps == 0.0


def test_dock_drives_to_the_charger_and_reports_charging() -> None:
    d = basis.DockAtCharger(2.0, 0.0)
    going = d.decide(Snapshot(T, odometry=odo(), power=Power(20.0, 11.0, 0, T)), T)
    assert going.vx_mps > 0 and going.signal == ""
    docked = d.decide(Snapshot(T, odometry=odo(2.0), power=Power(20.0, 11.0, 1, T)), T)
    assert docked.signal == "docked" and docked.vx_mps == 0.0


def _face_scan(tilt_rad: float, distance_m: float = 1.5, half_width_m: float = 0.6) -> RangeScan:
    """A flat face crossing the x axis at `distance_m`, its normal turned by `tilt_rad`."""
    nx, ny = math.cos(tilt_rad), math.sin(tilt_rad)
    ranges = []
    for b in BEARINGS:
        dx, dy = math.cos(b), math.sin(b)
        denom = dx * nx + dy * ny
        r = distance_m * nx / denom if denom > 1e-6 else 8.0
        # Points of the face beyond its half width are not part of it.
        px, py = r * dx, r * dy
        along = -px * ny + py * nx + distance_m * ny
        ranges.append(r if 0 < r < 8.0 and abs(along) <= half_width_m else 8.0)
    return RangeScan(tuple(ranges), BEARINGS, 8.0, T)


def test_find_face_recovers_the_tilt_of_a_flat_face() -> None:
    for tilt in (-0.3, 0.0, 0.25):
        face = find_face(_face_scan(tilt), 0.0, math.radians(45), 3.0)
        assert face is not None
        assert abs(face.normal_rad - tilt) < 0.02
        assert abs(face.width_m - 1.2) < 0.15
    p = basis.BoxAlignmentFromLaser().decide(Snapshot(T, laser=_face_scan(0.2)), T)
    assert not p.active and p.signal == "box" and abs(p.value - 0.2) < 0.05


def test_goal_from_camera_reports_bearing_of_marker() -> None:
    g = basis.GoalFromCamera(0x00FF00)
    p = g.decide(Snapshot(T, camera=view(blob(10, 20, 5.0, 0x00FF00))), T)
    assert p.signal == "goal" and p.value > 0 and p.vyaw_radps > 0


def test_turn_about_uses_the_stage_start_heading() -> None:
    t = basis.TurnAbout(math.pi)
    mark = Mark(0.0, Pose2D(0, 0, 0.0), None)
    start = t.decide(Snapshot(T, odometry=odo(yaw=0.0), mark=mark), T)
    assert start.vyaw_radps > 0
    done = t.decide(Snapshot(T, odometry=odo(yaw=math.pi - 0.05), mark=mark), T)
    assert done.signal == "turned"


def test_back_off_reverses_then_stops() -> None:
    b = basis.BackOff(duration_s=1.0)
    mark = Mark(T, None, None)
    assert b.decide(Snapshot(T, mark=mark), T + 0.5).vx_mps < 0
    assert b.decide(Snapshot(T, mark=mark), T + 1.0).signal == "backed-off"


def test_view_of_end_backs_away_then_turns_towards_the_far_end() -> None:
    b = basis.ViewOfEnd(RED, aim_fraction=0.2, min_range_m=1.4)
    # The left end is in view and nearly ahead: nothing to do.
    ok = b.decide(Snapshot(T, camera=view(blob(70, 150, range_m=0.4))), T)
    assert ok.signal == "in-view" and ok.vx_mps == 0.0 and ok.vyaw_radps == 0.0
    # Close up with the left end beyond the image edge: back straight away first.
    close = b.decide(Snapshot(T, camera=view(blob(0, 120, range_m=0.5))), T)
    assert close.vx_mps < 0 and close.vyaw_radps == 0.0 and close.signal == ""
    # Far enough back: turn left, towards that end.
    far = b.decide(Snapshot(T, camera=view(blob(0, 120, range_m=1.6))), T)
    assert far.vx_mps == 0.0 and far.vyaw_radps > 0
    # The end in view but well off to the left: turn towards it.
    off = b.decide(Snapshot(T, camera=view(blob(5, 60, range_m=1.6))), T)
    assert off.vyaw_radps > 0 and off.signal == ""
    # Box not in view at all (too close to see): back away.
    lost = b.decide(Snapshot(T, camera=view()), T)
    assert lost.vx_mps < 0
    assert not b.decide(Snapshot(T), T).active


def test_cruise_on_heading_turns_first_then_drives_straight() -> None:
    b = basis.CruiseOnHeading(0.5, speed_mps=0.2)
    off = b.decide(Snapshot(T, odometry=odo(yaw=-0.5)), T)
    assert off.vx_mps == 0.0 and off.vyaw_radps > 0
    on = b.decide(Snapshot(T, odometry=odo(yaw=0.45)), T)
    assert on.vx_mps == 0.2 and on.signal == "on-heading" and on.vyaw_radps > 0
    assert not b.decide(Snapshot(T), T).active
    assert basis.Cruise(0.1).decide(Snapshot(T), T).vx_mps == 0.1


def test_keep_distance_inputs_key_is_the_blob_it_looks_at() -> None:
    keep = basis.KeepDistanceToColour(0xFF0000)
    red = Blob(0xFF0000, 50, 100.0, 60.0, 90, 110, 50, 70, 2.0)
    green = Blob(0x00FF00, 80, 30.0, 60.0, 20, 40, 50, 70, 1.0)

    def snap(t: float, *blobs: Blob, seen_at: float | None = None) -> Snapshot:
        view = BlobView(160, 120, blobs, 1.0, t if seen_at is None else seen_at)
        return Snapshot(time_s=t, camera=view)

    # out of sight (or stale, or no camera): one key, and the same (inactive) proposal
    blind = [snap(1.0, green), snap(2.0), snap(3.0, red, seen_at=1.0), Snapshot(time_s=4.0)]
    assert {keep.inputs_key(s, s.time_s) for s in blind} == {0}
    assert {keep.decide(s, s.time_s) for s in blind} == {keep.decide(blind[0], 1.0)}
    # in sight: the key follows the blob, whatever else the camera sees
    a, b = snap(5.0, red), snap(6.0, red, green)
    assert keep.inputs_key(a, 5.0) == keep.inputs_key(b, 6.0) != 0
    assert keep.decide(a, 5.0) == keep.decide(b, 6.0) and keep.decide(a, 5.0).active
    moved = snap(7.0, Blob(0xFF0000, 50, 120.0, 60.0, 110, 130, 50, 70, 2.0))
    assert keep.inputs_key(moved, 7.0) != keep.inputs_key(a, 5.0)
