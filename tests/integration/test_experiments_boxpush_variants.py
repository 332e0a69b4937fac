"""The MURDOCH paper's box-pushing stresses, end to end: the goal far off to one side, a goal
that moves during the run, and the watch task re-targeted to another goal mid-run.

Real server (lockstep), real robot processes joined over loopback multicast, real PyBullet.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from experiments import events as ev
from experiments.summary import terminal_state_problems

pytestmark = pytest.mark.timeout(500)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(tmp_path: Path, *args: str,
         plots: bool = False) -> tuple[Path, list[dict[str, Any]], dict[str, Any]]:
    """A boxpush run with `args`; its plots only when the test looks at them."""
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "boxpush", "--seed", "2", "--no-replay",
         *(() if plots else ("--no-plots",)), "--out", str(out), *args],
        capture_output=True, text=True, timeout=450, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    events = ev.read_events(run / "events.jsonl")
    summary = json.loads((run / "summary.json").read_text())
    assert not any(terminal_state_problems(events).values())
    assert summary["goal"]["reached"], summary["goal"]
    assert "goal reached" in proc.stdout
    if plots:
        assert (run / "plots" / "box_distance.png").stat().st_size > 10_000
    else:
        assert not list(run.glob("plots/*.png"))
        assert f"plots          none drawn (murdoch report {run} draws them)" in proc.stdout
    return run, events, summary


def _needs(run: Path) -> list[tuple[float, tuple[str, ...]]]:
    needs = []
    for line in (run / "logs" / "watcher.events.jsonl").read_text().splitlines():
        d = json.loads(line)
        if d.get("kind") == "need":
            needs.append((float(d["time_s"]), tuple(d["tasks"])))
    return needs


def test_goal_far_off_to_one_side_single_corrective_pushes_first(tmp_path: Path) -> None:
    run, events, _ = _run(tmp_path, "--world", "boxpush_side", "--until", "11m")
    needs = _needs(run)
    # the box starts about 40 degrees off the goal: the watcher asks for one end only (the
    # right end turns the box to the left, towards the goal) until it is in line
    first = needs[: 5]
    assert all(tasks == ("push-right-end",) for _, tasks in first), first
    kinds = Counter(tasks for _, tasks in needs)
    assert kinds[("push-left-end", "push-right-end")] > 0  # then straight pushing
    track = [(e["t"], e["distance_m"], e["box"]) for e in events
             if e["kind"] == ev.BOX_PROGRESS]
    start_yaw, end_yaw = track[0][2][2], track[-1][2][2]
    assert end_yaw - start_yaw > math.radians(20)  # the box was rotated towards the goal
    assert track[-1][1] <= 2.5 < track[0][1] - 5.0


def test_a_goal_that_moves_during_the_run(tmp_path: Path) -> None:
    run, events, _ = _run(tmp_path, "--goal-velocity", "0,-0.006", "--until", "8m",
                          plots=True)
    track = [(e["t"], e["goal"], e["box"]) for e in events if e["kind"] == ev.BOX_PROGRESS]
    t_end, goal_end, box_end = track[-1]
    assert track[0][1] == [5.0, 1.0]
    assert goal_end[1] == pytest.approx(1.0 - 0.006 * t_end, abs=0.02)
    assert goal_end[1] < 0.0  # it moved more than a metre
    # the box arrived where the goal was by then, not where it started
    assert math.hypot(goal_end[0] - box_end[0], goal_end[1] - box_end[1]) <= 2.5
    config = json.loads((run / "config.json").read_text())
    assert config["goal_velocity_mps"] == [0.0, -0.006]


def test_the_watch_task_re_targeted_to_another_goal(tmp_path: Path) -> None:
    run, events, summary = _run(tmp_path, "--world", "boxpush_goals", "--retarget",
                                "goal2@40s", "--until", "8m")
    # drawn later, from the run directory alone, as the run's end block says
    proc = subprocess.run([*_murdoch(), "report", str(run)], capture_output=True, text=True,
                          timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("tasks.png", "allocation.png", "box_distance.png"):
        assert f"wrote      {run / 'plots' / name}" in proc.stdout
        assert (run / "plots" / name).stat().st_size > 10_000
    rebuilt = json.loads((run / "summary.json").read_text())
    assert (rebuilt["events_sha256"], rebuilt["tasks"]) == (summary["events_sha256"],
                                                           summary["tasks"])
    (moved,) = [e for e in events if e["kind"] == ev.GOAL_MOVED]
    assert moved["t"] == pytest.approx(40.0, abs=0.11) and moved["marker"] == "goal2"
    watch = [e for e in events if e["kind"] == ev.TASK_INTRODUCED
             and e["task_kind"] == "watch-box"]
    assert [w["task"] for w in watch][1] == moved["task"]
    assert watch[1]["params"]["goal_colour"] == "#00ff00"
    outcome = {e["task"]: e for e in events if e["kind"] == ev.TASK_OUTCOME}
    assert outcome[moved["replaces"]]["reason"] == "re-targeted to goal2"
    awards = [e for e in events if e["kind"] == ev.AWARD and e["task"] == moved["task"]]
    assert awards and awards[0]["robot"] == "watcher"
    last = [e for e in events if e["kind"] == ev.BOX_PROGRESS][-1]
    assert last["goal"] == [5.0, -1.8] and last["distance_m"] <= 2.5
    bx, by, _ = last["box"]
    assert math.hypot(5.0 - bx, 1.0 - by) > 2.5  # not at the first goal
    assert summary["goal"]["goal_moves"] == 1
