"""Group tasks: their needs as data, where the watchers stand, the stream and the judge."""

from __future__ import annotations

import itertools
import math
import random
from typing import Any

import pytest

from experiments.group_tasks import (
    CLEARANCE_M,
    SIDE_DISTANCE_M,
    WATCH_PAIR,
    WATCH_SIDE,
    GroupTask,
    PairJudge,
    assign_spots,
    group_outcome,
    group_summary,
    side_spots,
    watch_pair,
    with_group_tasks,
)
from experiments.task_source import longterm_tasks
from worlds import load_world, world_path


@pytest.fixture(scope="module")
def spec() -> Any:
    return load_world(world_path("longterm"))


def test_a_watch_pair_names_two_members_with_their_equipment_and_spots(spec: Any) -> None:
    group = watch_pair(spec, random.Random(3), 90.0)
    assert group is not None and group.kind == WATCH_PAIR and group.required == 2
    obj = next(o for o in spec.objects if o.name == group.target["object"])
    for member, (x, y) in zip(group.members, group.spots, strict=True):
        assert member.kind == WATCH_SIDE and member.equipment == {"mobile", "camera"}
        assert member.params["duration_s"] == 90.0
        assert math.hypot(x - obj.pose.x, y - obj.pose.y) == pytest.approx(SIDE_DISTANCE_M,
                                                                           abs=2e-3)
    (ax, ay), (bx, by) = group.spots
    # opposite sides: the object is the midpoint
    assert ((ax + bx) / 2, (ay + by) / 2) == pytest.approx((obj.pose.x, obj.pose.y), abs=2e-3)


def test_the_needs_survive_the_round_trip_through_the_event_params(spec: Any) -> None:
    group = watch_pair(spec, random.Random(1), 60.0)
    assert group is not None
    params = group.as_params()
    assert params["required"] == 2
    assert params["members"][0]["equipment"] == ["camera", "mobile"]
    assert GroupTask.from_params(WATCH_PAIR, params) == group
    params["required"] = 3
    with pytest.raises(ValueError, match="required 3 but 2 members"):
        GroupTask.from_params(WATCH_PAIR, params)


def test_spots_keep_clear_of_walls_obstacles_and_chargers(spec: Any) -> None:
    # the purple ball stands 1.4 m below the bench: the spot above it would touch the bench
    for seed in range(20):
        spots = side_spots(spec, -1.0, 2.5, random.Random(seed))
        assert spots is not None
        assert all(y < 3.9 - CLEARANCE_M for _, y in spots)
    # in a corner there is no room on two opposite sides
    assert side_spots(spec, 5.6, 4.6, random.Random(0)) is None


def test_spots_keep_clear_of_polygon_obstacles_by_their_outline(spec: Any) -> None:
    import dataclasses

    from worlds import ObstacleSpec, Pose

    # A low wedge, apex (0, -3), base from (-3, -4) to (3, -4): the spots 1.2 m either side
    # of (0, -2.8) are 0.57 m from its slopes, but 0.2 m from its bounding box.
    wedge = ObstacleSpec.polygon("wedge", Pose(0.0, -3.0, 0.0),
                                 ((-3.0, -1.0), (3.0, -1.0), (0.0, 0.0)), 0.5, 0)
    box = ObstacleSpec("box", Pose(0.0, -3.5, 0.0), "box", 6.0, 1.0, 0.5, 0)
    for ob, want in ((wedge, ((1.2, -2.8), (-1.2, -2.8))), (box, None)):
        arena = dataclasses.replace(spec.arena, obstacles=(ob,))
        world = dataclasses.replace(spec, arena=arena, chargers=())
        got = side_spots(world, 0.0, -2.8, random.Random(0))
        assert got == want or (got is not None and set(got) == set(want or ()))


def test_no_group_tasks_leaves_the_stream_exactly_as_it_was(spec: Any) -> None:
    plain = list(itertools.islice(longterm_tasks(spec, random.Random(2)), 30))
    mixed = list(itertools.islice(with_group_tasks(longterm_tasks(spec, random.Random(2)),
                                                   spec, random.Random(9), 0.0), 30))
    assert mixed == plain


def test_a_fraction_of_the_stream_becomes_group_tasks_at_the_same_times(spec: Any) -> None:
    plain = list(itertools.islice(longterm_tasks(spec, random.Random(2)), 200))
    mixed = list(itertools.islice(with_group_tasks(longterm_tasks(spec, random.Random(2)),
                                                   spec, random.Random(9), 0.3), 200))
    assert [p.t_s for p in mixed] == [p.t_s for p in plain]
    groups = [(m, p) for m, p in zip(mixed, plain, strict=True) if m.kind == WATCH_PAIR]
    assert 40 <= len(groups) <= 80
    assert all(m.params["duration_s"] == p.params["duration_s"] for m, p in groups)
    assert all(m == p for m, p in zip(mixed, plain, strict=True) if m.kind != WATCH_PAIR)
    again = list(itertools.islice(with_group_tasks(longterm_tasks(spec, random.Random(2)),
                                                   spec, random.Random(9), 0.3), 200))
    assert again == mixed
    with pytest.raises(ValueError, match="fraction"):
        next(with_group_tasks(iter([]), spec, random.Random(0), 1.5))


def test_each_spot_needs_a_robot_of_its_own() -> None:
    spots = ((0.0, 1.0), (0.0, -1.0))
    assert assign_spots(spots, {"p1": (0.1, 1.0), "p2": (0.0, -1.2)}, 0.5) == ("p1", "p2")
    assert assign_spots(spots, {"p1": (0.1, 1.0), "p2": (0.0, 1.1)}, 0.5) is None
    # one robot near both spots (they are close) cannot hold both
    close = ((0.0, 0.2), (0.0, -0.2))
    assert assign_spots(close, {"p1": (0.0, 0.0)}, 0.5) is None
    assert assign_spots(close, {"p1": (0.0, 0.0), "p2": (0.0, 0.3)}, 0.5) == ("p2", "p1")


def _pair(hold_s: float = 10.0) -> GroupTask:
    from experiments.group_tasks import GroupMember

    members = tuple(GroupMember(WATCH_SIDE, frozenset({"mobile", "camera"}),
                                {"x": 0.0, "y": y, "colour": "#ff0000"}) for y in (1.0, -1.0))
    return GroupTask(WATCH_PAIR, members, 60.0, hold_s=hold_s)


def test_the_judge_wants_both_in_place_for_the_hold_without_a_break() -> None:
    judge = PairJudge(_pair(hold_s=10.0))
    both = {"p1": (0.0, 1.0), "p2": (0.0, -1.0), "p3": (3.0, 3.0)}
    one = {"p1": (0.0, 1.0), "p2": (2.0, -1.0)}
    assert judge.update(0.0, both) is None
    assert judge.update(6.0, both) is None
    assert judge.update(7.0, one) is None  # a break: the hold starts again
    assert judge.update(8.0, both) is None
    assert judge.update(17.9, both) is None
    assert judge.update(18.0, both) == ("p1", "p2")


def test_a_member_that_ends_first_ends_its_group() -> None:
    assert group_outcome([]) is None
    assert group_outcome(["completed"]) == "failed"
    assert group_outcome(["failed", "unachievable"]) == "unachievable"


def test_the_summary_counts_group_tasks_by_how_they_ended() -> None:
    events = [
        {"t": 1.0, "kind": "task_introduced", "task": "group-1", "task_kind": WATCH_PAIR,
         "group": True},
        {"t": 1.0, "kind": "task_introduced", "task": "m1", "task_kind": WATCH_SIDE,
         "source": "group", "parent": "group-1"},
        {"t": 2.0, "kind": "task_introduced", "task": "group-2", "task_kind": WATCH_PAIR,
         "group": True},
        {"t": 3.0, "kind": "task_introduced", "task": "group-3", "task_kind": WATCH_PAIR,
         "group": True},
        {"t": 20.0, "kind": "task_outcome", "task": "group-1", "outcome": "completed",
         "in_place_s": 19.0},
        {"t": 30.0, "kind": "task_outcome", "task": "m1", "outcome": "completed"},
        {"t": 40.0, "kind": "task_outcome", "task": "group-2", "outcome": "unachievable"},
        {"t": 50.0, "kind": "task_outcome", "task": "group-3", "outcome": "failed",
         "reason": "run ended"},
    ]
    s = group_summary(events)
    assert s["group_tasks_completed"] == 1
    assert s["group_tasks"] == {"introduced": 3, "completed": 1, "failed": 0,
                                "unachievable": 1, "open_at_end": 1, "in_place_mean_s": 19.0}


def test_the_end_of_a_run_says_how_its_group_tasks_went() -> None:
    from experiments.end_report import summary_lines

    base = {"sim_time_s": 60.0, "tasks": {"introduced": 3, "executed": 1, "failed": 0,
                                          "unachievable": 0, "reallocations": 0},
            "charging_trips": 0, "robot_failures": 0,
            "messages": {"total": 5, "total_bytes": 500},
            "invariant_terminal_states": {"holds": True}}
    assert not any(line.startswith(("groups", "allocator")) for line in summary_lines(base))
    lines = summary_lines({**base, "allocator": "cbga", "group_tasks": {
        "introduced": 2, "completed": 1, "failed": 1, "unachievable": 0, "open_at_end": 0,
        "in_place_mean_s": 19.5}})
    assert lines[0] == "allocator  cbga"
    assert ("groups     introduced 2  completed 1  failed 1  unachievable 0  open at end 0  "
            "(in place 19.5 s after introduction, mean)") in lines
