"""The Player replay's drivers over a small recording written here."""

from __future__ import annotations

from pathlib import Path

import pytest

from player_server.protocol import constants as c
from player_server.record import channels as ch
from player_server.record.reader import RecordingError
from player_server.record.writer import McapSink
from player_server.replay.drivers import replay_drivers
from player_server.replay.source import RecordedRun, ReplayClock

ROBOTS = {
    "r1": {"mobile": True,
           "body": {"length": 0.4, "width": 0.3, "height": 0.2, "offset_x": 0.0},
           "devices": {"position2d": {}, "sonar": {"poses": [[0.1, 0, 0.2, 0], [0, 0.1, 0.2, 1.5]],
                                                  "max_range": 5.0},
                       "power": {}, "blobfinder": {"width": 160, "height": 120}}},
}


def _recording(path: Path) -> Path:
    sink = McapSink(path)
    sink.put(ch.WORLD_INFO, 0.0, {"world": "w", "interval_s": 0.1, "record_rate_hz": 2.0,
                                  "robots": ROBOTS})
    for k in range(1, 5):
        t = 0.5 * k
        sink.put("/r1/odometry", t, {"timestamp": ch.stamp(t), "x": t, "y": 0.0, "yaw": 0.1,
                                     "vx": 0.2, "vy": 0.0, "vyaw": 0.0, "stall": False})
        sink.put("/r1/sonar_ranges", t, {"timestamp": ch.stamp(t), "ranges": [t, -1.0]})
        sink.put("/r1/battery", t, {"timestamp": ch.stamp(t), "percent": 90.0 - k,
                                    "charging": k % 2, "volts": 12.5, "watts": 20.0,
                                    "joules": 1e5})
        sink.put("/r1/blobs", t, {"timestamp": ch.stamp(t), "width": 160, "height": 120,
                                  "blobs": [[1, 0xFF0000, 40, 10, 20, 5, 15, 18, 22, 1.5]]})
    sink.close()
    return path


def test_each_device_serves_the_newest_recorded_message(tmp_path: Path) -> None:
    run = RecordedRun(_recording(tmp_path / "run.mcap"))
    assert run.world == "w" and run.end_s == pytest.approx(2.0)
    drivers = replay_drivers(run, "r1")
    kinds = {key[0] for key in drivers}
    assert kinds == {int(c.Interface.POSITION2D), int(c.Interface.SONAR),
                     int(c.Interface.POWER), int(c.Interface.BLOBFINDER)}
    pos = drivers[(int(c.Interface.POSITION2D), 0)]
    sonar = drivers[(int(c.Interface.SONAR), 0)]
    power = drivers[(int(c.Interface.POWER), 0)]
    blobs = drivers[(int(c.Interface.BLOBFINDER), 0)]
    clock = ReplayClock(run)
    assert pos.data() == ()  # nothing recorded yet at t = 0
    clock.step(7)  # t = 0.7: the sample of 0.5
    (_, body), = pos.data()
    assert body.pos.px == pytest.approx(0.5) and body.vel.px == pytest.approx(0.2)
    (_, sbody), = sonar.data()
    assert sbody.ranges == pytest.approx((0.5, 0.0))  # an unusable range is served as 0
    (_, pbody), = power.data()
    assert pbody.percent == pytest.approx(89.0) and pbody.charging == 1
    assert pbody.watts < 0  # Player's sign: consuming
    (_, bbody), = blobs.data()
    assert bbody.width == 160 and bbody.blobs[0].area == 40
    clock.step(13)  # t = 2.0
    assert pos.data()[0][1].pos.px == pytest.approx(2.0)
    # commands are taken and ignored; geometry comes from the recorded world
    pos.handle_command(c.PLAYER_POSITION2D_CMD_VEL, None)
    assert pos.ignored_commands == 1
    geom = pos.handle_request(c.PLAYER_POSITION2D_REQ_GET_GEOM, None).body
    assert geom.size.sl == pytest.approx(0.4)
    assert len(sonar.handle_request(c.PLAYER_SONAR_REQ_GET_GEOM, None).body.poses) == 2


def test_a_recording_without_world_info_is_refused(tmp_path: Path) -> None:
    sink = McapSink(tmp_path / "run.mcap")
    sink.put(ch.TF, 0.0, ch.frame_transforms(0.0, {"a": (0.0, 0.0, 0.0)}))
    sink.close()
    with pytest.raises(RecordingError, match="not a run recording"):
        RecordedRun(tmp_path / "run.mcap")


def test_a_recorded_world_that_does_not_fit_is_named(tmp_path: Path) -> None:
    from player_server.replay.serve import build_server

    path = tmp_path / "run.mcap"
    sink = McapSink(path)
    sink.put(ch.WORLD_INFO, 0.0, {"world": "w", "interval_s": 0.1, "robots": {
        "r1": {"mobile": True, "devices": {}}}})  # no body, no laser layout
    sink.put("/r1/laser", 0.5, {"ranges": [1.0]})
    sink.close()
    with pytest.raises(RecordingError, match="robot 'r1' of the recorded world"):
        build_server(RecordedRun(path), 0)
