"""Writing a recording on its own thread and reading it back, whole or cut short."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from player_server.record import channels as ch
from player_server.record.reader import RecordingError, iter_messages, read_info
from player_server.record.writer import McapSink


def _write(path: Path, seconds: int, chunk_size: int = 1 << 20) -> None:
    sink = McapSink(path, clock=time.monotonic, chunk_size=chunk_size)
    for k in range(seconds * 2):
        t = k * 0.5
        sink.put(ch.TF, t, ch.frame_transforms(t, {"p1": (0.01 * k, 0.0, 0.0)}))
        sink.put(ch.robot_topic("p1", ch.BATTERY), t, lambda t=t: {
            "timestamp": ch.stamp(t), "percent": 100.0 - t / 10, "charging": 0,
            "volts": 12.0, "watts": 30.0, "joules": 1.0})
    sink.put(ch.EVENTS, 1.0, ch.log_message(1.0, "run_start", '{"t":1.0}'))
    sink.put(ch.EVENTS, 2.0, {"bad": float("nan")})  # not JSON: counted, not written
    sink.put(ch.TF, 3.0, {"x": 1})
    sink.close()
    assert sink.dropped == 1 and sink.error is None


def test_write_and_read_back(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, 60)
    info = read_info(path)
    assert info.complete and not info.truncated and info.profile == "murdoch"
    assert info.channels[ch.TF].messages == 121 and info.channels[ch.TF].schema == (
        "foxglove.FrameTransforms")
    assert info.channels["/p1/battery"].messages == 120
    assert info.channels[ch.EVENTS].messages == 1
    assert info.duration_s == pytest.approx(59.5)
    times = [r.t_s for r in iter_messages(path, topics=["/p1/battery"])]
    assert times == [k * 0.5 for k in range(120)]
    assert read_info(tmp_path).path == path  # a run directory names its run.mcap


def test_a_file_cut_short_reads_up_to_its_last_whole_chunk(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, 600, chunk_size=16 * 1024)  # many small chunks
    whole = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) // 2])
    info = read_info(cut)
    assert not info.complete and info.truncated
    n = info.channels[ch.TF].messages
    assert 200 < n < 1200
    assert info.end_ns > 0
    assert len(list(iter_messages(cut, topics=[ch.TF]))) == n


def test_what_is_not_a_recording_is_named(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no recording found"):
        read_info(tmp_path)
    bad = tmp_path / "x.mcap"
    bad.write_text('{"t": 0}\n')
    with pytest.raises(RecordingError, match="not an MCAP file"):
        read_info(bad)
