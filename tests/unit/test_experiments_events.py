"""events.jsonl: schema checks, the appending writer's flush policy, the tolerant reader."""

from __future__ import annotations

import json
import threading
from datetime import datetime
from pathlib import Path

import pytest

from experiments import events as ev
from experiments import rundir as rd


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_make_event_checks_required_fields_and_outcomes() -> None:
    e = ev.make_event(12.5, ev.AWARD, task="t1", robot="p1", latency_s=0.4)
    assert e == {"t": 12.5, "kind": "award", "task": "t1", "robot": "p1", "latency_s": 0.4}
    with pytest.raises(ev.EventError, match=r"lacks field.*robot"):
        ev.make_event(1.0, ev.AWARD, task="t1")
    with pytest.raises(ev.EventError, match="outcome must be one of"):
        ev.make_event(1.0, ev.TASK_OUTCOME, task="t1", outcome="done")
    with pytest.raises(ev.EventError, match="finite"):
        ev.make_event(float("nan"), ev.ALARM, robot="p1")
    with pytest.raises(ev.EventError, match="finite"):
        ev.make_event(True, ev.ALARM, robot="p1")  # type: ignore[arg-type]
    # unknown kinds are allowed (forward compatible), with t and kind
    assert ev.make_event(3, "custom", x=1)["kind"] == "custom"


def test_writer_appends_and_flushes_by_count_and_by_time(tmp_path: Path) -> None:
    clock = FakeClock()
    path = tmp_path / "events.jsonl"
    w = ev.EventWriter(path, clock=clock, flush_every=3, flush_period_s=10.0)
    w.write(0.0, ev.ROBOT_FAILURE, robot="p1")
    w.write(0.1, ev.ROBOT_RESTART, robot="p1")
    assert path.read_text() == ""  # buffered
    w.write(0.2, ev.CHARGE_START, robot="p2")
    assert len(path.read_text().splitlines()) == 3  # flushed at the third line
    w.write(0.3, ev.CHARGE_END, robot="p2")
    assert len(path.read_text().splitlines()) == 3
    clock.now = 11.0
    w.write(0.4, ev.ALARM, robot="p3")
    assert len(path.read_text().splitlines()) == 5  # flushed because time passed
    w.close()
    # a second writer appends; it never truncates
    with ev.EventWriter(path, clock=clock) as w2:
        w2.write(0.5, ev.ALARM, robot="p3")
    assert [e["t"] for e in ev.read_events(path)] == [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    with pytest.raises(ValueError, match="closed"):
        w.write(1.0, ev.ALARM, robot="p3")


def test_writer_is_safe_from_many_threads(tmp_path: Path) -> None:
    path = tmp_path / "events.jsonl"
    with ev.EventWriter(path, clock=FakeClock(), flush_every=50) as w:

        def work(i: int) -> None:
            for k in range(500):
                w.write(float(k), ev.MESSAGE, msg_kind="bid", sender=f"r{i}", bytes=100)

        threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(10)
    stats = ev.ReadStats()
    events = ev.read_events(path, stats=stats)
    assert len(events) == 2000 and stats.malformed == 0


def test_writer_encodes_numpy_values(tmp_path: Path) -> None:
    import numpy as np

    path = tmp_path / "e.jsonl"
    with ev.EventWriter(path, clock=FakeClock()) as w:
        w.write(np.float64(1.5).item(), ev.BATTERY, percent={"p1": np.float32(42.5)})
    assert ev.read_events(path)[0]["percent"] == {"p1": 42.5}


def test_reader_skips_and_counts_malformed_lines(tmp_path: Path) -> None:
    path = tmp_path / "events.jsonl"
    good = json.dumps({"t": 1.0, "kind": "alarm", "robot": "p1"})
    path.write_text(
        "\n".join(
            [
                good,
                "not json",
                json.dumps([1, 2]),
                json.dumps({"kind": "alarm", "robot": "p1"}),  # no t
                json.dumps({"t": 2.0, "kind": "award", "task": "x"}),  # no robot
                "",
                good,
                '{"t": 3.0, "kind": "ala',  # a last line cut short by a crash
            ]
        )
    )
    stats = ev.ReadStats()
    events = ev.read_events(path, stats=stats)
    assert [e["t"] for e in events] == [1.0, 1.0]
    assert stats.malformed == 5


def test_run_dir_layout_and_config(tmp_path: Path) -> None:
    started = datetime(2026, 1, 2, 3, 4, 5)
    run = rd.create_run_dir(tmp_path / "runs", "longterm", started)
    assert run.root.name == "longterm-20260102-030405"
    assert run.plots.is_dir() and run.logs.is_dir()
    again = rd.create_run_dir(tmp_path / "runs", "longterm", started)
    assert again.root.name == "longterm-20260102-030405-2"
    with pytest.raises(ValueError, match="seed"):
        run.write_config({"experiment": "longterm"})
    run.write_config({"experiment": "longterm", "seed": 7, "world": "longterm"})
    assert run.read_config()["seed"] == 7
    assert run.log_file("robot-p1") == run.logs / "robot-p1.log"
    with pytest.raises(ValueError):
        run.log_file("../escape")
    with pytest.raises(ValueError):
        rd.create_run_dir(tmp_path, "bad/name", started)
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        rd.open_run_dir(run.root)
    run.events.write_text("")
    assert rd.open_run_dir(run.root).root == run.root
