"""Task execution: stages, signals, events, done/failed, progress; the task library."""

from __future__ import annotations

import math
import random

import pytest

from behaviors.arbiter import Layer
from behaviors.basis import Hold
from behaviors.contract import random_snapshot
from behaviors.library import TASKS, needed_push, task_spec
from behaviors.params import ParamError, colour_of, parse_assignments
from behaviors.profile import Charger, OverheadView, RobotProfile, subjects_for
from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import Blob, BlobView, Odometry, Pose2D, Snapshot
from behaviors.task import Stage, TaskExecution, TaskPlan, elapsed, signal

H = Hold()
EVERYTHING = frozenset(
    {"mobile", "sonar", "laser", "camera", "bumper", "gripper", "power", "overhead-camera"}
)
PROFILE = RobotProfile("r1", EVERYTHING, chargers=(Charger("c", 1.0, 1.0, 0.3),),
                       overhead=OverheadView(0.0, 0.0, 10.0, 8.0))


def say(sig: str = "", vx: float = 0.0) -> Proposal:
    return Proposal(True, vx, 0.0, 1.0, sig, 1.0)


def test_stages_advance_on_signals_and_emit_events() -> None:
    plan = TaskPlan(
        "t",
        (
            Stage("a", (Layer(H),), until=signal("go", held_s=0.2)),
            Stage("b", (Layer(H),), until=signal("end"), alarms=(("intruder", "alarm"),)),
        ),
    )
    ex = TaskExecution(plan, 0.0)
    assert ex.stage.name == "a"
    assert ex.step(Snapshot(0.1), 0.1, [say("go", 0.1)]).outcome == "running"
    r = ex.step(Snapshot(0.2), 0.2, [say("go")])
    assert r.vx_mps == 0.0 and ex.stage.name == "a"
    r = ex.step(Snapshot(0.3), 0.3, [say("go")])
    assert ex.stage.name == "b" and r.events == (("stage", (("stage", "b"),)),)
    r = ex.step(Snapshot(0.4), 0.4, [say("intruder")])
    assert r.events[0][0] == "alarm"
    r = ex.step(Snapshot(0.5), 0.5, [say("intruder")])
    assert r.events == ()  # rising edge only
    r = ex.step(Snapshot(0.6), 0.6, [say("end")])
    assert r.outcome == "done" and ex.progress() == 1.0
    assert ex.step(Snapshot(0.7), 0.7, [say()]).outcome == "done"


def test_failure_timeout_and_repeat() -> None:
    plan = TaskPlan("t", (Stage("a", (Layer(H),), timeout_s=1.0),))
    ex = TaskExecution(plan, 0.0)
    assert ex.step(Snapshot(0.5), 0.5, [INACTIVE]).outcome == "running"
    r = ex.step(Snapshot(1.0), 1.0, [INACTIVE])
    assert r.outcome == "failed" and "timed out" in r.reason
    loop = TaskPlan("l", (Stage("a", (Layer(H),), until=signal("x")),), repeat_from=0,
                    done=lambda v: v.loops >= 2)
    ex = TaskExecution(loop, 0.0)
    ex.step(Snapshot(0.1), 0.1, [say("x")])
    assert ex.view.loops == 1 and ex.outcome == "running"
    assert ex.step(Snapshot(0.2), 0.2, [say("x")]).outcome == "running"
    assert ex.step(Snapshot(0.3), 0.3, [say()]).outcome == "done"


def test_mark_is_taken_at_stage_start() -> None:
    plan = TaskPlan("t", (Stage("a", (Layer(H),), until=signal("x")),
                          Stage("b", (Layer(H),))))
    s0 = Snapshot(0.0, odometry=Odometry(Pose2D(1, 2, 0.5), 0, 0, False, 0.0))
    ex = TaskExecution(plan, 0.0, s0)
    assert ex.mark.pose == Pose2D(1, 2, 0.5)
    s1 = Snapshot(3.0, odometry=Odometry(Pose2D(4, 5, 1.0), 0, 0, False, 3.0))
    ex.step(s1, 3.0, [say("x")])
    assert ex.mark.pose == Pose2D(4, 5, 1.0) and ex.mark.time_s == 3.0


def test_every_library_task_builds_and_runs_on_random_data() -> None:
    rng = random.Random(5)
    params = {"x": 1.0, "y": 2.0, "colour": "red", "goal_colour": "#00ff00",
              "colours": "red,green"}
    for name, spec in TASKS.items():
        plan = spec.build(params, PROFILE)
        assert plan.name == name
        ex = TaskExecution(plan, 0.0)
        for i in range(60):
            t = 0.1 * (i + 1)
            snap = random_snapshot(rng, t, colours=(0xFF0000, 0x00FF00)).with_mark(ex.mark)
            proposals = [b.decide(snap, t) for b in ex.behaviours()]
            r = ex.step(snap, t, proposals)
            assert math.isfinite(r.vx_mps) and math.isfinite(r.vyaw_radps)
            assert abs(r.vx_mps) <= plan.max_speed_mps
            assert 0.0 <= ex.progress() <= 1.0


def test_duration_tasks_finish_and_internal_tasks_exist() -> None:
    plan = task_spec("object-tracking").build({"colour": "red", "duration_s": 1.0}, PROFILE)
    ex = TaskExecution(plan, 0.0)
    assert ex.step(Snapshot(0.5), 0.5, [INACTIVE] * len(ex.behaviours())).outcome == "running"
    assert ex.step(Snapshot(1.0), 1.0, [INACTIVE] * len(ex.behaviours())).outcome == "done"
    assert task_spec("dock").build({"x": 1, "y": 1}, PROFILE).name == "dock"
    with pytest.raises(ParamError, match="unknown task"):
        task_spec("fly")
    with pytest.raises(ParamError, match="missing parameter"):
        task_spec("goto-goal").build({"x": 1.0}, PROFILE)


def test_metrics_prefer_the_closer_and_better_aligned_robot() -> None:
    goto = task_spec("goto-goal")
    near = Snapshot(1.0, odometry=Odometry(Pose2D(1, 1, 0), 0, 0, False, 1.0))
    far = Snapshot(1.0, odometry=Odometry(Pose2D(5, 5, 0), 0, 0, False, 1.0))
    params = {"x": 0.0, "y": 0.0}
    assert goto.score(near, params, PROFILE) > goto.score(far, params, PROFILE)  # type: ignore[operator]
    assert goto.score(Snapshot(1.0), params, PROFILE) is None
    # Weights named by an announcement replace the defaults.
    assert goto.metric_names() == ("distance", "battery")
    only_distance = goto.score(near, params, PROFILE, [("distance", 2.0)])
    assert only_distance == pytest.approx(-2.0 * math.sqrt(2.0))
    with pytest.raises(ParamError, match="no metric"):
        goto.score(near, params, PROFILE, [("charisma", 1.0)])
    no_sonar = RobotProfile("r2", frozenset({"mobile", "laser"}))
    assert goto.score(near, params, no_sonar) is None

    push = task_spec("push-left-end")

    def seen(left: int, right: int) -> Snapshot:
        blob = Blob(0xFF0000, 100, (left + right) / 2, 60, left, right, 50, 70, 2.0)
        return Snapshot(1.0, camera=BlobView(160, 120, (blob,), math.radians(60), 1.0))

    aimed = seen(60, 160)  # left end (20% across) near the image centre
    off = seen(0, 60)
    assert push.score(aimed, {"colour": "red"}, PROFILE) > push.score(  # type: ignore[operator]
        off, {"colour": "red"}, PROFILE
    )


def test_watcher_decision_and_helpers() -> None:
    assert needed_push(0.3, 0.1) == ("push-left-end",)
    assert needed_push(-0.3, 0.1) == ("push-right-end",)
    assert needed_push(0.05, 0.1) == ("push-left-end", "push-right-end")
    assert colour_of("#00ff00") == 0x00FF00 and colour_of(0x123456) == 0x123456
    with pytest.raises(ParamError, match="colour"):
        colour_of("purple-ish")
    assert parse_assignments(["x=1.5", "colour=red"]) == {"x": 1.5, "colour": "red"}
    with pytest.raises(ParamError, match="KEY=VALUE"):
        parse_assignments(["oops"])
    assert subjects_for({"position2d", "laser", "blobfinder"}) == {"mobile", "laser", "camera"}
    assert subjects_for({"blobfinder", "camera"}) == {"overhead-camera"}
    assert PROFILE.nearest_charger(0.0, 0.0).name == "c"  # type: ignore[union-attr]
    _ = elapsed(1.0)
