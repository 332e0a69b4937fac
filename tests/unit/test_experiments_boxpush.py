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
