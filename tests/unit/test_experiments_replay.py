"""Replay keyframe decimation and animation tracks (pure)."""

from __future__ import annotations

import itertools
import math

import pytest

from experiments import events as ev
from experiments.replay import build_replay_commands, decimate
from player_server.viz import scene


def test_still_body_keeps_first_and_last_key() -> None:
    keys = [(float(t), 1.0, 2.0, 0.0) for t in range(1000)]
    assert decimate(keys, max_keys=100) == [keys[0], keys[-1]]


def test_stop_and_go_keeps_the_key_before_the_move() -> None:
    keys = [(float(t), 0.0, 0.0, 0.0) for t in range(10)]
    keys += [(10.0 + t, 0.1 * (t + 1), 0.0, 0.0) for t in range(5)]
    kept = decimate(keys, max_keys=100)
    times = [k[0] for k in kept]
    assert times == [0.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0]


def test_moving_body_is_thinned_to_the_cap() -> None:
    keys = [(float(t), math.cos(t / 50), math.sin(t / 50), t / 50) for t in range(20000)]
    kept = decimate(keys, max_keys=500)
    assert len(kept) == 500
    assert kept[0] == keys[0] and kept[-1] == keys[-1]
    assert all(a[0] < b[0] for a, b in itertools.pairwise(kept))
    with pytest.raises(ValueError):
        decimate(keys, max_keys=1)


def test_animation_tracks_and_state_visibility() -> None:
    layout = scene.SceneLayout(
        -2, -2, 2, 2, robots=(scene.RobotShape("r1", 0.4, 0.4, 0, 0, 0),)
    )
    poses = [{"t": float(t), "kind": ev.POSES, "bodies": {"r1": [0.1 * t, 0, 0], "x": [0, 0, 0]}}
             for t in range(601)]
    events = [
        ev.make_event(0, ev.TASK_INTRODUCED, task="t1", task_kind="cleanup"),
        ev.make_event(100, ev.AWARD, task="t1", robot="r1"),
        ev.make_event(400, ev.TASK_OUTCOME, task="t1", outcome="completed"),
    ]
    cmds, info = build_replay_commands(layout, poses, events, max_playback_s=60)
    assert info["speed"] == pytest.approx(10.0)
    assert info["bodies"] == 1  # "x" is not in the scene
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    pos = clips["/murdoch/robots/r1"]["tracks"][0]
    assert pos["name"] == ".position" and pos["times"][-1] == pytest.approx(60.0)
    working = clips["/murdoch/robots/r1/body/working"]["tracks"][0]
    assert working["type"] == "bool"
    assert list(zip(working["times"], working["values"], strict=True)) == [
        (0.0, False), (10.0, True), (40.0, False), (60.0, False)
    ]
    # the label block over simulated time: [t, state, colour, battery, task, target, marked]
    rows = info["timeline"]["r1"]
    assert [(r[0], r[1], r[4]) for r in rows] == [
        (100.0, "working", "cleanup t1"), (400.0, "idle", "")]
    datas = [c["path"] for c in cmds if c["type"] == "set_object"
             and c["object"]["object"].get("name") == "murdoch-data"]
    assert datas == ["/murdoch/hud/legend", "/murdoch/robots/r1/info"]
