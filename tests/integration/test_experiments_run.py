"""`murdoch run longterm` end to end: real server, robot processes, multicast auctions."""

from __future__ import annotations

import json
import os
import pstats
import subprocess
import sys
from pathlib import Path

import pytest

from experiments import events as ev
from experiments.summary import terminal_state_problems

pytestmark = pytest.mark.timeout(240)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def test_short_longterm_run_with_a_killed_winner(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--until", "120s", "--task-interval", "25",
         "--seed", "4", "--kill", "busy@45s", "--restart", "busy@90s", "--out", str(out)],
        capture_output=True, text=True, timeout=220, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    for name in ("config.json", "events.jsonl", "poses.jsonl", "summary.json", "replay.html",
                 "plots/tasks.png", "plots/battery.png", "plots/allocation.png"):
        assert (run / name).is_file(), name
    config = json.loads((run / "config.json").read_text())
    assert config["seed"] == 4
    cpus = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else set()
    if len(cpus) >= 2:  # the serving thread got a CPU of its own (the default)
        pinned = config["cpu_affinity"]
        assert len(pinned["serving"]) == 1 and pinned["serving"][0] not in pinned["others"]
    events = ev.read_events(run / "events.jsonl")
    # every task ends in exactly one terminal state
    assert not any(terminal_state_problems(events).values())
    summary = json.loads((run / "summary.json").read_text())
    assert summary["sim_time_s"] >= 119.0
    assert summary["tasks"]["introduced"] >= 4
    assert {"announce", "bid", "award"} <= set(summary["messages"]["by_kind"])
    # the robot holding a task was killed; its task went back to auction and to another robot
    (failure,) = [e for e in events if e["kind"] == ev.ROBOT_FAILURE]
    victim = failure["robot"]
    realloc = [e for e in events if e["kind"] == ev.REALLOCATION]
    assert realloc and realloc[0]["from_robot"] == victim
    task = realloc[0]["task"]
    awards = [e["robot"] for e in events if e["kind"] == ev.AWARD and e["task"] == task]
    assert awards[0] == victim and any(r != victim for r in awards[1:])
    assert [e["robot"] for e in events if e["kind"] == ev.ROBOT_RESTART] == [victim]
    assert summary["processes"]["runner"]["peak_rss_bytes"] > 0
    assert "sim 0:02:00" in proc.stdout  # the final progress line


def test_short_boxpush_run_auctions_pushing_subtasks(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    profiles = tmp_path / "profiles"
    profiles.mkdir()
    proc = subprocess.run(
        [*_murdoch(), "run", "boxpush", "--until", "40s", "--seed", "2", "--no-replay",
         "--out", str(out)],
        capture_output=True, text=True, timeout=200, check=False,
        env={**os.environ, "MURDOCH_ROBOT_PROFILE_DIR": str(profiles)},
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    # each robot wrote a profile of its loop when it stopped
    written = sorted(p.stem for p in profiles.glob("*.prof"))
    assert written == ["pusher1", "pusher2", "watcher"]
    assert pstats.Stats(str(profiles / "watcher.prof")).total_calls > 1000  # type: ignore[attr-defined]
    (run,) = out.iterdir()
    events = ev.read_events(run / "events.jsonl")
    assert not any(terminal_state_problems(events).values())
    introduced = {e["task"]: e for e in events if e["kind"] == ev.TASK_INTRODUCED}
    awards = {e["task"]: e["robot"] for e in events if e["kind"] == ev.AWARD}
    (watch,) = [t for t, e in introduced.items() if e["task_kind"] == "watch-box"]
    assert awards[watch] == "watcher"
    pushes = [t for t, e in introduced.items() if e["task_kind"].startswith("push-")]
    assert pushes and all(introduced[t]["source"] == "watcher" for t in pushes)
    assert {awards[t] for t in pushes if t in awards} <= {"pusher1", "pusher2"}
    assert any(t in awards for t in pushes)


def test_short_run_completes_tasks_and_sends_robots_to_charge(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--world", "test_lowbattery", "--until", "110s",
         "--task-interval", "30", "--seed", "1", "--no-replay", "--out", str(out)],
        capture_output=True, text=True, timeout=200, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    summary = json.loads((run / "summary.json").read_text())
    assert summary["tasks"]["executed"] >= 1
    assert summary["charging_trips"] >= 1
    assert summary["invariant_terminal_states"]["holds"]
    events = ev.read_events(run / "events.jsonl")
    starts = [e for e in events if e["kind"] == ev.CHARGE_START]
    ends = [e for e in events if e["kind"] == ev.CHARGE_END]
    assert ends and ends[0]["robot"] == starts[0]["robot"] and ends[0]["t"] > starts[0]["t"]
    # charging trips are completed cycles: each robot's ends that close an open start
    open_: set[str] = set()
    cycles = 0
    for e in events:
        if e["kind"] == ev.CHARGE_START:
            open_.add(e["robot"])
        elif e["kind"] == ev.CHARGE_END and e["robot"] in open_:
            open_.discard(e["robot"])
            cycles += 1
    assert summary["charging_trips"] == cycles
    assert summary["charging_starts"] == len(starts)


def test_specialist_and_distance_terms_give_tracking_to_the_camera_only_robots(
    tmp_path: Path,
) -> None:
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--until", "150s", "--task-interval", "20",
         "--seed", "4", "--metric", "distance,specialist", "--no-replay", "--out", str(out)],
        capture_output=True, text=True, timeout=220, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    assert json.loads((run / "config.json").read_text())["metric_terms"] == [
        "distance", "specialist"]
    events = ev.read_events(run / "events.jsonl")
    assert not any(terminal_state_problems(events).values())
    kind = {e["task"]: e["task_kind"] for e in events if e["kind"] == ev.TASK_INTRODUCED}
    first_award: dict[str, dict] = {}
    specialist_bid: set[str] = set()
    for e in events:
        if e["kind"] == ev.AWARD:
            first_award.setdefault(e["task"], e)
        elif (e["kind"] == ev.MESSAGE and e["msg_kind"] == "bid"
              and e["sender"] in ("p5", "p6") and e.get("task") not in first_award):
            specialist_bid.add(str(e.get("task")))
    contested = [t for t, k in kind.items() if k == "object-tracking" and t in specialist_bid
                 and t in first_award]
    assert contested, kind
    for task in contested:
        award = first_award[task]
        # a camera-only robot that bid beats every generalist (one spare resource fewer)
        assert award["robot"] in ("p5", "p6"), award
        assert award["bid"] < 0.0  # the specialist term (-6 per spare resource) is in it
