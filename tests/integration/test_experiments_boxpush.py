"""`murdoch run boxpush` end to end: the watcher leads, the pushers push, the box arrives.

Real server (lockstep), real robot processes joined over loopback multicast, real PyBullet.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from experiments import events as ev
from experiments.report import recorded_poses
from experiments.summary import terminal_state_problems

pytestmark = pytest.mark.timeout(400)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(tmp_path: Path, *args: str, wall_s: float = 300.0, plots: bool = False) -> tuple[
        subprocess.CompletedProcess[str], Path, list[dict[str, Any]], dict[str, Any]]:
    """A boxpush run with `args`; its plots only when the test looks at them."""
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "boxpush", *(() if "--seed" in args else ("--seed", "2")),
         "--no-replay", *(() if plots else ("--no-plots",)), "--out", str(out), *args],
        capture_output=True, text=True, timeout=wall_s, check=False,
    )
    (run,) = out.iterdir()
    assert (run / "summary.json").is_file(), (  # (the run's own words on why it stopped)
        f"exit {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}")
    events = ev.read_events(run / "events.jsonl")
    summary = json.loads((run / "summary.json").read_text())
    return proc, run, events, summary


def _box_track(run: Path, box: str = "bigbox") -> list[tuple[float, float, float]]:
    track = []
    for d in recorded_poses(run / "run.mcap"):
        x, y, _ = d["bodies"][box]
        track.append((float(d["t"]), float(x), float(y)))
    return track


def test_two_pushers_get_the_box_to_the_goal(tmp_path: Path) -> None:
    proc, run, events, summary = _run(tmp_path, "--until", "1200s")
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert not any(terminal_state_problems(events).values())
    (reached,) = [e for e in events if e["kind"] == ev.GOAL_REACHED]
    assert reached["distance_m"] <= reached["radius_m"]
    # the run ended soon after the box arrived, well before --until
    assert summary["goal"]["reached"] and not summary["goal"]["unachievable"]
    assert summary["sim_time_s"] < reached["t"] + 30.0 < 1230.0
    # the ground truth agrees: the box moved several metres towards the goal marker
    _, x0, y0 = _box_track(run)[0]
    goal_x, goal_y = 5.0, 1.0
    assert math.hypot(goal_x - x0, goal_y - y0) - reached["distance_m"] > 4.0
    introduced = {e["task"]: e for e in events if e["kind"] == ev.TASK_INTRODUCED}
    awards = {e["task"]: e["robot"] for e in events if e["kind"] == ev.AWARD}
    pushers = {awards[t] for t, e in introduced.items()
               if e["task_kind"].startswith("push-") and t in awards}
    assert pushers == {"pusher1", "pusher2"}
    assert "goal reached" in proc.stdout


def test_one_pusher_switched_off_and_back_on(tmp_path: Path) -> None:
    proc, run, events, summary = _run(
        tmp_path, "--until", "900s", "--switch-off", "p1@40s", "--switch-on", "p1@150s")
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert not any(terminal_state_problems(events).values())
    (off,) = [e for e in events if e["kind"] == ev.ROBOT_SWITCH_OFF]
    (on,) = [e for e in events if e["kind"] == ev.ROBOT_SWITCH_ON]
    assert off["robot"] == on["robot"] == "pusher1"
    introduced = {e["task"]: e for e in events if e["kind"] == ev.TASK_INTRODUCED}
    awards = [(e["t"], e["task"], e["robot"]) for e in events if e["kind"] == ev.AWARD
              and introduced.get(e["task"], {}).get("task_kind", "").startswith("push-")]
    alone = [(introduced[task]["task_kind"], robot) for t, task, robot in awards
             if off["t"] < t < on["t"]]
    # the remaining pusher see-saws: it pushes both ends in turn
    assert {robot for _, robot in alone} == {"pusher2"}
    assert {"push-left-end", "push-right-end"} <= {kind for kind, _ in alone}
    track = _box_track(run)
    x_off = next(x for t, x, _ in track if t >= off["t"])
    x_on = next(x for t, x, _ in track if t >= on["t"])
    assert x_on - x_off > 0.5  # the box kept moving while one pusher was off
    # the returning pusher takes part again, and the box reaches the goal
    assert any(robot == "pusher1" for t, _, robot in awards if t > on["t"])
    assert summary["goal"]["reached"], (track[-1], proc.stdout[-1500:])
    _assert_roles_swapped(summary, off, on)


def _assert_roles_swapped(summary: dict[str, Any], off: dict[str, Any],
                          on: dict[str, Any]) -> None:
    """Per end: the returning pusher works the other end from before, the other pusher
    takes its old end."""
    pushes = summary["goal"]["pushes"]
    phases = pushes["phases"]
    old_end = off["end"]
    new_end = {"left": "right", "right": "left"}[old_end]
    assert on["end"] == new_end
    before, after = phases["before"]["pusher1"], phases["after"]["pusher1"]
    assert before.get(old_end, 0) > before.get(new_end, 0), phases
    assert after.get(new_end, 0) > after.get(old_end, 0), phases
    other = phases["after"]["pusher2"]
    assert other.get(old_end, 0) > other.get(new_end, 0), phases
    assert pushes["role_swap"] == {"robot": "pusher1", "end_before": old_end,
                                   "end_after": new_end, "swapped": True}
    assert set(phases["alone"]) == {"pusher2"}
    assert summary["goal"]["final_distance_m"] <= 2.5


def test_the_returning_pusher_waits_for_the_other_to_work_its_old_end(tmp_path: Path) -> None:
    """Switched on while the remaining pusher pushed its own end, the returning pusher used to
    be the only one free for the next push of its old end, and kept that end. The switch-on
    now waits until the remaining pusher works the old end."""
    proc, run, events, summary = _run(
        tmp_path, "--until", "600s", "--seed", "3", "--switch-off", "p1@50s",
        "--switch-on", "p1@100s", wall_s=360.0, plots=True)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (off,) = [e for e in events if e["kind"] == ev.ROBOT_SWITCH_OFF]
    (on,) = [e for e in events if e["kind"] == ev.ROBOT_SWITCH_ON]
    assert on["asked_t"] == 100.0 and 100.0 <= on["t"] <= 160.0
    assert on["other_at_old_end"] is True
    _assert_roles_swapped(summary, off, on)
    assert (run / "plots" / "box_distance.png").stat().st_size > 10_000


def test_no_pusher_left_is_an_unachievable_error(tmp_path: Path) -> None:
    proc, _, events, summary = _run(
        tmp_path, "--until", "400s", "--switch-off", "p1@20s", "--switch-off", "p2@20s")
    assert proc.returncode == 4, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "unachievable" in proc.stderr
    assert not any(terminal_state_problems(events).values())
    (err,) = [e for e in events if e["kind"] == ev.GOAL_UNACHIEVABLE]
    assert "nobody could do push-" in err["reason"]
    assert summary["goal"]["unachievable"] and not summary["goal"]["reached"]
    outcomes = [e for e in events if e["kind"] == ev.TASK_OUTCOME
                and e["outcome"] == ev.UNACHIEVABLE]
    assert outcomes and summary["tasks"]["unachievable"] >= 1
    assert summary["sim_time_s"] < 300.0  # it ended on the error, not at --until
