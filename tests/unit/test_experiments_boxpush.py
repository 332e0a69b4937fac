"""The box-pushing referee's pure geometry and the short robot names."""

from __future__ import annotations

import math

import pytest

from experiments import boxpush as bp
from worlds import load_world, world_path


def test_box_goal_of_the_boxpush_world() -> None:
    bg = bp.box_goal(load_world(world_path("boxpush")))
    assert bg.box == "bigbox" and bg.goal_xy == (5.0, 1.0)
    assert bg.box_half_depth_m == pytest.approx(0.25)
    assert bg.box_half_length_m == pytest.approx(0.7)


def test_resolve_robot_accepts_short_names() -> None:
    names = ("watcher", "pusher1", "pusher2")
    assert bp.resolve_robot("pusher2", names) == "pusher2"
    assert bp.resolve_robot("p1", names) == "pusher1"
    with pytest.raises(ValueError, match="no robot"):
        bp.resolve_robot("p3", names)
    with pytest.raises(ValueError, match="no robot"):
        bp.resolve_robot("q1", names)


def test_return_pose_is_behind_the_other_end_facing_the_goal() -> None:
    bg = bp.BoxGoal("box", "goal", (5.0, 0.0), 0.25, 0.7)
    box = (0.0, 0.0, 0.0)
    assert bp.side_of(box, (-1.0, 0.45)) == pytest.approx(0.45)
    x, y, yaw = bp.return_pose(box, bg.goal_xy, -0.45, bg, gap_m=0.9)
    assert (x, y, yaw) == pytest.approx((-1.15, -0.45, 0.0))
    # a box turned a quarter turn: its long axis is along world x; behind = away from the goal
    turned = (0.0, 0.0, math.pi / 2)
    x, y, yaw = bp.return_pose(turned, (0.0, 5.0), 0.45, bg, gap_m=0.9)
    assert (x, y) == pytest.approx((-0.45, -1.15))
    assert yaw == pytest.approx(math.pi / 2)


def test_odometry_at_is_relative_to_the_start_pose() -> None:
    assert bp.odometry_at((-4.4, 0.45, 0.0), (-2.4, 0.45, 0.3)) == pytest.approx((2.0, 0.0, 0.3))
    x, y, yaw = bp.odometry_at((1.0, 1.0, math.pi / 2), (1.0, 2.0, math.pi / 2))
    assert (x, y, yaw) == pytest.approx((1.0, 0.0, 0.0))


class _Sim:
    def __init__(self) -> None:
        self.poses = {"bigbox": (2.0, 1.0, 0.0), "p1": (0.0, 0.0, 0.0)}

    def get_pose(self, name: str) -> tuple[float, float, float]:
        return self.poses[name]


def test_goal_watch_and_sim_actions() -> None:
    bg = bp.BoxGoal("bigbox", "goal", (5.0, 1.0), 0.25, 0.7)
    watch = bp.GoalWatch(bg, radius_m=2.5, robots=("p1",))
    sim = _Sim()
    watch.sample(sim, 10.0)
    assert watch.distance_m == pytest.approx(3.0) and watch.reached_at_s is None
    assert watch.robot_poses == {"p1": (0.0, 0.0, 0.0)}
    sim.poses["bigbox"] = (3.0, 1.0, 0.0)
    watch.sample(sim, 11.0)
    watch.sample(sim, 12.0)
    assert watch.reached_at_s == 11.0
    done: list[str] = []
    actions = bp.SimActions()
    actions.put(lambda s: done.append("a"))
    actions.put(lambda s: done.append("b"))
    actions.apply(sim, 0.0)
    actions.apply(sim, 0.0)
    assert done == ["a", "b"]


def test_ends_of_the_box_as_seen_from_behind() -> None:
    bg = bp.BoxGoal("box", "goal", (5.0, 0.0), 0.25, 0.7)
    box = (0.0, 0.0, 0.0)  # pushed along +x: its +y end is on the pushers' left
    assert bp.end_offset(box, bg.goal_xy, "left", bg) == pytest.approx(0.5)
    assert bp.end_offset(box, bg.goal_xy, "right", bg) == pytest.approx(-0.5)
    assert bp.end_at(box, bg.goal_xy, (-1.0, 0.4)) == "left"
    assert bp.end_at(box, bg.goal_xy, (-1.0, -0.4)) == "right"
    # the same box pushed along -x (goal behind it): the ends swap sides
    assert bp.end_offset(box, (-5.0, 0.0), "left", bg) == pytest.approx(-0.5)
    assert bp.end_at(box, (-5.0, 0.0), (1.0, 0.4)) == "right"
    for end in ("left", "right"):
        pose = bp.return_pose(box, bg.goal_xy, bp.end_offset(box, bg.goal_xy, end, bg), bg)
        assert bp.end_at(box, bg.goal_xy, pose[:2]) == end


def test_a_moving_goal_stops_short_of_the_walls() -> None:
    plan = bp.GoalPlan((0.0, -0.01))
    assert plan.moving and not bp.GoalPlan().moving
    assert plan.goal_at((5.0, 1.0), 100.0, (14.0, 8.0)) == pytest.approx((5.0, 0.0))
    assert plan.goal_at((5.0, 1.0), 1000.0, (14.0, 8.0)) == pytest.approx((5.0, -3.4))


def test_goal_options_are_checked() -> None:
    assert bp.parse_velocity("0,-0.01") == (0.0, -0.01)
    for bad in ("0.1", "a,b", "nan,0", "1,0"):
        with pytest.raises(ValueError, match=r"VX,VY|up to 0\.5"):
            bp.parse_velocity(bad)
    world = load_world(world_path("boxpush_goals"))
    assert bp.marker_goal(world, "goal2") == ((5.0, -1.8), 0x00FF00)
    with pytest.raises(ValueError, match=r"no marker 'goal9' .*goal, goal2"):
        bp.marker_goal(world, "goal9")


def test_the_side_world_puts_the_goal_far_off_the_pushing_direction() -> None:
    world = load_world(world_path("boxpush_side"))
    bg = bp.box_goal(world)
    box = next(b for b in world.boxes if b.name == bg.box)
    bearing = math.atan2(bg.goal_xy[1] - box.pose.y, bg.goal_xy[0] - box.pose.x)
    assert math.degrees(bearing - box.pose.yaw) > 35.0
