"""`murdoch report RUN_DIR` through the installed entry point, on a recorded run directory."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest

from experiments import events as ev
from experiments import rundir as rd
from player_server.record import channels as ch
from player_server.record.writer import McapSink

pytestmark = pytest.mark.timeout(120)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _record_run(root: Path) -> rd.RunDir:
    run = rd.create_run_dir(root, "longterm", datetime(2026, 3, 4, 5, 6, 7))
    run.write_config({"experiment": "longterm", "seed": 11, "world": "longterm"})
    clock = iter(range(10**6)).__next__
    sink = McapSink(run.recording)
    with ev.EventWriter(run.events, clock=lambda: float(clock())) as w:
        w.write(0, ev.RUN_START, experiment="longterm", seed=11)
        for k in range(30):
            t = 60.0 * k
            w.write(t, ev.TASK_INTRODUCED, task=f"t{k}", task_kind="sentry-duty")
            w.write(t + 0.1, ev.MESSAGE, msg_kind="announce", sender="user", task=f"t{k}",
                    bytes=180)
            w.write(t + 0.6, ev.AWARD, task=f"t{k}", robot=f"p{k % 6 + 1}")
            w.write(t + 50, ev.TASK_OUTCOME, task=f"t{k}", robot=f"p{k % 6 + 1}",
                    outcome="completed")
            w.write(t + 30, ev.BATTERY, percent={f"p{i}": 100 - k - i for i in range(1, 7)})
            for s in range(60):
                poses = {f"p{i}": (-4 + i + 0.01 * s, 0.0, 0.0) for i in range(1, 7)}
                sink.put(ch.TF, t + s, ch.frame_transforms(t + s, poses))
        w.write(1800, ev.CHARGE_START, robot="p3")
        w.write(1900, ev.CHARGE_END, robot="p3")
        w.write(1900, ev.PROCESS, name="robot-p1", pid=123, rss_bytes=50_000_000)
        w.write(1900, ev.RUN_END, wall_s=60.0, reason="completed")
    sink.close()
    with run.events.open("a") as f:
        f.write('{"t": 1901, "kind": "award", "tas')  # cut short
    return run


def test_report_rebuilds_summary_plots_and_replay(tmp_path: Path) -> None:
    run = _record_run(tmp_path / "runs")
    proc = subprocess.run([*_murdoch(), "report", str(run.root), "--replay"],
                          capture_output=True, text=True, timeout=100, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "executed 30" in proc.stdout
    assert "1 malformed event line(s) skipped" in proc.stdout
    summary = json.loads(run.summary.read_text())
    assert summary["tasks"]["executed"] == 30
    assert summary["charging_trips"] == 1
    assert summary["real_time_factor"] == pytest.approx(1900 / 60.0, rel=1e-3)
    assert summary["invariant_terminal_states"]["holds"] is True
    assert summary["malformed_event_lines"] == 1
    for name in ("tasks.png", "battery.png", "allocation.png"):
        assert (run.plots / name).stat().st_size > 5000
    assert run.replay.stat().st_size > 800_000  # the viewer script is embedded
    # rebuilding is repeatable
    first = run.summary.read_text()
    shutil.rmtree(run.plots)
    proc = subprocess.run([*_murdoch(), "report", str(run.root)], capture_output=True,
                          text=True, timeout=100, check=False)
    assert proc.returncode == 0, proc.stderr
    assert run.summary.read_text() == first
    assert (run.plots / "tasks.png").exists()


def test_report_on_a_directory_that_is_not_a_run(tmp_path: Path) -> None:
    proc = subprocess.run([*_murdoch(), "report", str(tmp_path)], capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode != 0
    assert "not a run directory" in proc.stderr
