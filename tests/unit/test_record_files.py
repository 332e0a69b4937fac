"""Writing a recording in its own process and reading it back, whole or cut short."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from player_server.record import channels as ch
from player_server.record.reader import RecordingError, iter_messages, read_info
from player_server.record.writer import McapSink


def _battery(t: float) -> dict[str, object]:
    return {"timestamp": ch.stamp(t), "percent": 100.0 - t / 10, "charging": 0,
            "volts": 12.0, "watts": 30.0, "joules": 1.0}


def _write(path: Path, seconds: int, chunk_size: int = 1 << 20) -> None:
    sink = McapSink(path, chunk_size=chunk_size)
    for k in range(seconds * 2):
        t = k * 0.5
        sink.put(ch.TF, t, ch.frame_transforms(t, {"p1": (0.01 * k, 0.0, 0.0)}))
        sink.put(ch.robot_topic("p1", ch.BATTERY), t, partial(_battery, t))
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


def test_the_observer_comes_back_and_what_cannot_travel_is_counted(tmp_path: Path) -> None:
    from experiments.recording import DrivenFromTf

    path = tmp_path / "run.mcap"
    sink = McapSink(path, observer=DrivenFromTf(["p1", "p2"]))
    for k in range(11):
        sink.put(ch.TF, k * 0.5, ch.frame_transforms(k * 0.5, {"p1": (0.1 * k, 0.0, 0.0),
                                                               "box": (k, 0.0, 0.0)}))
    sink.put(ch.EVENTS, 6.0, lambda: {"a": 1})  # a lambda cannot reach the writer process
    sink.put(ch.EVENTS, 6.5, ch.log_message(6.5, "run_end", '{"t":6.5}'))
    sink.close()
    assert (sink.written, sink.dropped, sink.error) == (12, 1, None)
    assert isinstance(sink.observer, DrivenFromTf)
    assert sink.observer.lengths.summary() == {"by_robot": {"p1": 1.0, "p2": 0.0}, "total": 1.0}
    assert read_info(path).channels[ch.EVENTS].messages == 1
    with pytest.raises(ValueError, match="is closed"):
        sink.put(ch.TF, 7.0, {})


def _moment(t: float, robots: tuple[str, ...]) -> list[tuple[str, float, object]]:
    """The messages of one moment, made in the writer process (one of them not JSON)."""
    items: list[tuple[str, float, object]] = [
        (ch.TF, t, ch.frame_transforms(t, {r: (t, 0.0, 0.0) for r in robots}))]
    items += [(ch.robot_topic(r, ch.BATTERY), t, partial(_battery, t)) for r in robots]
    items.append((ch.EVENTS, t, {"bad": float("nan")}))
    return items


def _no_moment(t: float) -> list[tuple[str, float, object]]:
    raise ValueError(f"no readings at {t}")


def test_a_group_is_made_into_its_messages_in_the_writer_process(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    sink = McapSink(path)
    for k in range(4):
        sink.put_group(k * 0.5, partial(_moment, k * 0.5, ("p1", "p2")))
    sink.put_group(2.0, partial(_no_moment, 2.0))  # a group that cannot be made: counted once
    sink.put(ch.TF, 2.5, ch.frame_transforms(2.5, {"p1": (0.0, 0.0, 0.0)}))
    sink.close()
    # per moment, /tf and two batteries written; the message that is not JSON and the group
    # that could not be made counted, the rest of the recording kept
    assert (sink.written, sink.dropped, sink.error) == (13, 5, None)
    order = [(r.topic, r.t_s) for r in iter_messages(path)]
    assert order[:3] == [(ch.TF, 0.0), ("/p1/battery", 0.0), ("/p2/battery", 0.0)]
    assert order[-1] == (ch.TF, 2.5)
    assert [r.json()["percent"] for r in iter_messages(path, topics=["/p2/battery"])] == [
        100.0, 99.95, 99.9, 99.85]


_DIES = """
import os, sys
from player_server.record import channels as ch
from player_server.record.writer import McapSink
sink = McapSink(sys.argv[1], chunk_size=4096)
for k in range(2000):
    sink.put(ch.TF, k * 0.5, ch.frame_transforms(k * 0.5, {"p1": (0.01 * k, 0.0, 0.0)}))
if sys.argv[2] == "exit":
    os._exit(3)  # the recording process dies without closing
raise SystemExit(3)  # it ends without closing (multiprocessing terminates the daemon)
"""


@pytest.mark.parametrize("how", ["exit", "raise"])
def test_the_writer_finishes_the_file_when_the_recording_process_dies(
        tmp_path: Path, how: str) -> None:
    import subprocess
    import sys
    import time

    path = tmp_path / "run.mcap"
    done = subprocess.run([sys.executable, "-c", _DIES, str(path), how], timeout=120,
                          check=False)
    assert done.returncode == 3
    # the writer, orphaned, writes what it got and the summary; wait (bounded) for it
    info = None
    for _ in range(600):
        try:
            info = read_info(path)
        except RecordingError:  # (not even the header yet)
            info = None
        if info is not None and info.complete:
            break
        time.sleep(0.1)
    assert info is not None and info.complete and not info.truncated
    assert info.channels[ch.TF].messages == 2000


def test_a_writer_that_dies_stops_the_recording_not_the_recorder(tmp_path: Path) -> None:
    import os
    import signal
    import time

    path = tmp_path / "run.mcap"
    sink = McapSink(path, chunk_size=4096)
    for k in range(400):
        sink.put(ch.TF, k * 0.5, ch.frame_transforms(k * 0.5, {"p1": (0.01 * k, 0.0, 0.0)}))
    pid = sink.writer_pid
    assert pid is not None
    # kill it once some chunks are on disk (it flushes every second; bounded wait)
    for _ in range(1200):
        tf = read_info(path).channels.get(ch.TF)
        if tf is not None and tf.messages > 0:
            break
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    for k in range(400, 100_000):  # puts go on without raising until the loss is noticed
        sink.put(ch.TF, k * 0.5, ch.frame_transforms(k * 0.5, {"p1": (0.0, 0.0, 0.0)}))
        if sink.error is not None:
            break
    sink.close()
    assert sink.error is not None and "writer process" in sink.error
    info = read_info(path)  # what was flushed reads back, cut short
    assert info.truncated and not info.complete
    assert info.channels[ch.TF].messages > 0


def test_a_writer_killed_at_once_leaves_a_file_that_reads_as_cut_short(tmp_path: Path) -> None:
    import os
    import signal

    path = tmp_path / "run.mcap"
    sink = McapSink(path)
    pid = sink.writer_pid
    assert pid is not None
    os.kill(pid, signal.SIGKILL)  # before anything but the header was written
    sink.close()
    assert sink.error is not None
    info = read_info(path)
    assert info.truncated and not info.complete and not info.channels


def test_threads_that_record_at_once_lose_nothing(tmp_path: Path) -> None:
    import threading

    path = tmp_path / "run.mcap"
    sink = McapSink(path)
    scan = [1.0 + 0.001 * k for k in range(700)]  # each batch well over a pipe's atomic write

    def record(robot: str) -> None:
        for k in range(150):
            t = 0.5 * k
            sink.put_many([(ch.robot_topic(robot, ch.LASER), t,
                            ch.laser_scan(t, robot, (0.0, 0.0, 0.2, 0.0), -1.5, 1.5, scan))] * 3)

    threads = [threading.Thread(target=record, args=(f"p{n}",)) for n in range(1, 5)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(timeout=120)
    sink.close()
    assert (sink.written, sink.dropped, sink.error) == (1800, 0, None)
    info = read_info(path)
    assert all(info.channels[f"/p{n}/laser"].messages == 450 for n in range(1, 5))


def test_a_writer_slow_to_start_loses_nothing(tmp_path: Path) -> None:
    # not waiting at all for the writer's "ready" stands for a machine so loaded that the
    # writer process is still starting when the wait ends: the recording goes on
    path = tmp_path / "run.mcap"
    sink = McapSink(path, chunk_size=4096, startup_s=0.0)
    assert sink.error is None
    for k in range(200):
        sink.put(ch.robot_topic("p1", ch.BATTERY), k * 0.5, _battery(k * 0.5))
    sink.close()
    assert sink.error is None and sink.dropped == 0 and sink.written == 200
    info = read_info(path)
    assert info.complete and info.channels["/p1/battery"].messages == 200
