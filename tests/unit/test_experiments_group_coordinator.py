"""The runner's group coordinator: members handed out, groups judged and ended once.

Fakes stand in for the node, the recorder and the simulation; the runs themselves are in
tests/integration/test_experiments_compare.py."""

from __future__ import annotations

import random
from typing import Any

import pytest

from experiments.group_coordinator import GroupCoordinator
from experiments.group_tasks import watch_pair
from experiments.task_source import PlannedTask
from worlds import load_world, world_path


class FakeNode:
    def __init__(self) -> None:
        self.announced: list[tuple[str, Any]] = []
        self.cancelled: list[tuple[str, str]] = []

    def announce(self, spec: Any, patience_s: float | None = None) -> str:
        task_id = f"user.0.{len(self.announced) + 1}"
        self.announced.append((task_id, spec))
        return task_id

    def open_tasks(self) -> tuple[str, ...]:
        done = {t for t, _ in self.cancelled}
        return tuple(t for t, _ in self.announced if t not in done)

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        self.cancelled.append((task_id, reason))


class FakeRec:
    def __init__(self) -> None:
        self.events: list[dict[str, Any]] = []

    def event(self, t: float, kind: str, **fields: Any) -> None:
        self.events.append({"t": t, "kind": kind, **fields})


class FakeSim:
    def __init__(self) -> None:
        self.poses: dict[str, tuple[float, float, float]] = {
            f"p{i}": (-5.0 + i, -4.0, 0.0) for i in range(1, 7)}

    def get_pose(self, name: str) -> tuple[float, float, float]:
        return self.poses[name]


def _coordinator() -> tuple[GroupCoordinator, FakeNode, FakeRec, FakeSim, Any]:
    spec = load_world(world_path("longterm"))
    group = watch_pair(spec, random.Random(4), 90.0)
    assert group is not None
    node, rec, sim = FakeNode(), FakeRec(), FakeSim()
    c = GroupCoordinator(rec=rec, node=node, sim=sim,
                         mobile=frozenset(f"p{i}" for i in range(1, 7)), introduced=set(),
                         finished=set(), patience_s=300.0,
                         member_spec=lambda kind, params, parent: (kind, dict(params), parent))
    c.introduce(PlannedTask(5.0, group.kind, group.as_params()), 5.0)
    return c, node, rec, sim, group


def _outcomes(rec: FakeRec, task: str) -> list[dict[str, Any]]:
    return [e for e in rec.events if e["kind"] == "task_outcome" and e["task"] == task]


def test_members_are_handed_out_as_tasks_of_their_own_under_the_group() -> None:
    c, node, rec, _, group = _coordinator()
    assert [spec for _, spec in node.announced] == [
        (m.kind, dict(m.params), "group-1") for m in group.members]
    intro = [e for e in rec.events if e["kind"] == "task_introduced"]
    assert intro[0]["task"] == "group-1" and intro[0]["group"] is True
    assert intro[0]["params"]["required"] == 2
    assert [(e["source"], e["parent"]) for e in intro[1:]] == [("group", "group-1")] * 2
    assert c.introduced == {"group-1", "user.0.1", "user.0.2"}


def test_the_group_completes_when_both_spots_are_held_and_its_members_go_on() -> None:
    c, node, rec, sim, group = _coordinator()
    (ax, ay), (bx, by) = group.spots
    sim.poses["p2"], sim.poses["p5"] = (ax + 0.2, ay, 0.0), (bx, by - 0.1, 0.0)
    c.step(10.0)
    c.step(19.9)
    assert not _outcomes(rec, "group-1")
    c.step(20.0)
    (done,) = _outcomes(rec, "group-1")
    assert done["outcome"] == "completed" and done["robots"] == ["p2", "p5"]
    assert done["in_place_s"] == pytest.approx(15.0)
    assert c.finished == {"group-1"} and not node.cancelled
    c.on_outcome("user.0.1", "completed", 90.0)
    c.step(90.0)
    assert len(_outcomes(rec, "group-1")) == 1


@pytest.mark.parametrize(("member_end", "outcome"), [("failed", "failed"),
                                                     ("completed", "failed"),
                                                     ("unachievable", "unachievable")])
def test_a_member_that_ends_first_ends_the_group_and_withdraws_the_other(
        member_end: str, outcome: str) -> None:
    c, node, rec, _, _ = _coordinator()
    c.on_outcome("user.0.2", member_end, 30.0)
    c.step(30.1)
    (end,) = _outcomes(rec, "group-1")
    assert end["outcome"] == outcome
    assert node.cancelled == [("user.0.1", f"group group-1 {outcome}")]


def test_a_group_not_in_place_by_its_deadline_fails() -> None:
    c, node, rec, _, group = _coordinator()
    c.step(5.0 + group.deadline_s - 0.1)
    assert not _outcomes(rec, "group-1")
    c.step(5.0 + group.deadline_s)
    (end,) = _outcomes(rec, "group-1")
    assert end["outcome"] == "failed" and "deadline" in end["reason"]
    assert sorted(t for t, _ in node.cancelled) == ["user.0.1", "user.0.2"]


def test_a_robot_that_is_down_holds_no_spot() -> None:
    c, _, rec, sim, group = _coordinator()
    (ax, ay), (bx, by) = group.spots
    sim.poses["p2"], sim.poses["p5"] = (ax, ay, 0.0), (bx, by, 0.0)
    c.step(10.0, down={"p5"})
    c.step(30.0, down={"p5"})  # p5 was killed where it stood: the hold never starts
    assert not _outcomes(rec, "group-1")
    c.step(31.0)
    c.step(41.0)
    (done,) = _outcomes(rec, "group-1")
    assert done["outcome"] == "completed" and done["in_place_s"] == pytest.approx(36.0)


def test_a_team_that_takes_groups_whole_is_handed_one_task() -> None:
    spec = load_world(world_path("longterm"))
    group = watch_pair(spec, random.Random(4), 90.0)
    assert group is not None
    node, rec = FakeNode(), FakeRec()
    c = GroupCoordinator(rec=rec, node=node, sim=FakeSim(), mobile=frozenset({"p1"}),
                         introduced=set(), finished=set(), patience_s=300.0, whole=True)
    c.introduce(PlannedTask(5.0, group.kind, group.as_params()), 5.0)
    ((task_id, announced),) = node.announced
    assert announced.name == group.kind and announced.parent == "group-1"
    assert dict(announced.params)["required"] == 2
    assert announced.subjects >= {"camera", "mobile"}
    intro = [e for e in rec.events if e["kind"] == "task_introduced"]
    assert [(e["task"], e.get("source")) for e in intro] == [("group-1", "user"),
                                                             (task_id, "group")]
    assert intro[1]["params"] == group.as_params()
    c.on_outcome(task_id, "failed", 20.0)  # the task ends before the group is in place
    c.step(20.1)
    (end,) = _outcomes(rec, "group-1")
    assert end["outcome"] == "failed"
