"""The member task of a group watch, as the robots' task library holds it."""

from __future__ import annotations

import math

import pytest

from behaviors.library import TASKS
from behaviors.params import ParamError
from behaviors.profile import RobotProfile
from experiments.group_tasks import WATCH_SIDE, member_equipment


def test_a_member_drives_to_its_spot_faces_the_object_and_holds() -> None:
    spec = TASKS[WATCH_SIDE]
    assert spec.subjects == member_equipment(WATCH_SIDE) == {"mobile", "camera"}
    profile = RobotProfile("p5", frozenset({"mobile", "camera", "sonar"}), seed=5)
    plan = spec.build({"colour": "#ff0000", "x": 3.5, "y": 3.7, "duration_s": 80.0}, profile)
    assert [s.name for s in plan.stages] == ["go", "face", "watch"]
    go, face, watch = plan.stages
    assert go.timeout_s == 240.0 and go.on_timeout == "fail"
    assert face.on_timeout == "next" and math.isinf(plan.timeout_s)
    assert {layer.behaviour.name for layer in go.layers} >= {"servo-to-location"}
    assert [layer.behaviour.name for layer in watch.layers] == ["hold"]
    with pytest.raises(ParamError, match="x"):
        spec.build({"colour": "#ff0000", "y": 1.0}, profile)
