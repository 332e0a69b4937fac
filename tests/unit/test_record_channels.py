"""The recording's layout: topics, schemas and message builders (pure)."""

from __future__ import annotations

import json
import math

import pytest

from player_server.record import channels as ch


def test_every_topic_has_a_schema_and_strangers_are_refused() -> None:
    for topic in ch.TOPIC_SCHEMAS:
        assert ch.schema_of(topic) in ch.SCHEMAS
    for what in ch.ROBOT_CHANNELS:
        assert ch.schema_of(ch.robot_topic("p1", what)) in ch.SCHEMAS
        assert ch.split_robot_topic(ch.robot_topic("p1", what)) == ("p1", what)
    assert ch.split_robot_topic(ch.TF) is None
    for bad in ("/p1/camera", "tf", "/p1/laser/x", ""):
        with pytest.raises(ValueError, match="not a topic"):
            ch.schema_of(bad)
    for name in ch.SCHEMAS:
        assert json.loads(ch.schema_bytes(name))["title"] == name


def test_stamps_and_poses_round_trip() -> None:
    assert ch.stamp(1.25) == {"sec": 1, "nsec": 250_000_000}
    assert ch.nanoseconds(3600.1) == 3_600_100_000_000
    poses = {"p1": (1.2345, -2.0, 3.0), "box": (0.0, 0.5, -1.5)}
    msg = json.loads(ch.encode(ch.frame_transforms(12.5, poses)))
    back = ch.poses_of(msg)
    assert back["p1"] == pytest.approx((1.234, -2.0, 3.0), abs=1e-3)  # millimetres kept
    assert back["box"] == pytest.approx((0.0, 0.5, -1.5), abs=1e-3)
    assert all(t["timestamp"] == {"sec": 12, "nsec": 500_000_000} for t in msg["transforms"])


def test_json_refuses_non_finite_numbers() -> None:
    with pytest.raises(ValueError):
        ch.encode({"x": math.nan})


def test_sonar_ring_as_a_scan_puts_each_echo_at_its_bearing() -> None:
    # front and left transducers 0.1 m from the centre; the rear one hears nothing
    mounts = [(0.1, 0.0, 0.0), (0.0, 0.1, math.pi / 2), (-0.1, 0.0, math.pi)]
    scan = ch.sonar_ring_scan(1.0, "p1", mounts, [1.0, 2.0, 5.0], max_range=5.0)
    bins = scan["ranges"]
    assert len(bins) == ch.SONAR_BINS and scan["start_angle"] == pytest.approx(-math.pi)
    step = (scan["end_angle"] - scan["start_angle"]) / (len(bins) - 1)
    hits = {round(math.degrees(scan["start_angle"] + k * step)): r
            for k, r in enumerate(bins) if r > 0}
    assert hits == {0: pytest.approx(1.1), 90: pytest.approx(2.1)}


def test_log_and_scene_messages_have_every_field_foxglove_reads() -> None:
    log = ch.log_message(2.0, "award", '{"t":2.0}', ch.LOG_WARNING)
    assert set(log) == {"timestamp", "level", "message", "name", "file", "line"}
    ent = ch.entity(0.0, "world", "wall/n", cubes=[ch.cube(0, 0, 0, 0, 1, 1, 1, 0xFF0000)])
    assert ent["cubes"][0]["color"] == {"r": 1.0, "g": 0.0, "b": 0.0, "a": 1.0}
    for key in ("arrows", "spheres", "cylinders", "lines", "triangles", "texts", "models"):
        assert ent[key] == []


@pytest.mark.parametrize("message", [
    {"x": 1.25, "ranges": [0.0, 1e-05, 12.5, 3.0], "s": "é \"q\" null", "n": None},
    {"x": math.inf}, {"x": -math.inf}, {"nested": [{"y": math.nan}]},
    {1: "an integer key"}, {"big": 2**70}, {"obj": object()},
])
def test_fast_json_means_what_the_standard_encoder_means(message: dict) -> None:
    """The recording's encoder gives the same JSON value as the standard library, and
    refuses what it refuses (non-finite numbers, objects that are not data) alike."""
    try:
        expected = json.loads(json.dumps(message, allow_nan=False))
    except (ValueError, TypeError) as exc:
        with pytest.raises(type(exc)):
            ch.encode(message)
    else:
        assert json.loads(ch.encode(message)) == expected
