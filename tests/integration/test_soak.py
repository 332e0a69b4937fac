"""`murdoch soak`: fifteen simulated minutes of `longterm` in the small low-battery world
under dense random faults keep every invariant, and a broken invariant makes the command exit
non-zero.

The faults are drawn from the seed as in any soak, at rates that put every kind (kill and
restart, freeze and thaw, a switch-off, a charger outage, a burst) into the first ten
minutes; the robots' tiny batteries send them to charge within the first minute and a half;
memory is sampled every tenth of a wall second, so the five minutes after the warm-up (600 s),
a few wall seconds in lockstep, hold enough samples to judge. The two-hour soak of the
six-robot world is opt-in: `tests/soak/test_longterm_soak.py`."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest
from soak_checks import check_soak_run, murdoch_command

from experiments import events as ev
from experiments.soak.report import SOAK_JSON

_murdoch = murdoch_command


SHORT_SOAK = ["--sim-hours", "0.25", "--seed", "11", "--world", "test_lowbattery",
              "--faults", "random", "--task-interval", "20",
              "--kills-per-hour", "20", "--kill-down", "20s-40s", "--freezes-per-hour", "20",
              "--freeze-for", "5s-20s", "--charger-outages-per-hour", "12",
              "--charger-outage", "1m-2m", "--burst-size", "15", "--memory-every", "0.1",
              # as in the two-hour soak: a short window cannot tell slow growth from warming
              # up (memory is judged from 600 s, the warm-up, to the end)
              "--memory-slope-limit", "30"]
"""Seed 11 draws, inside the 120-600 s fault window: a freeze, kills, a charger outage, a
switch-off and a burst (checked below from config.json, so a change in the draw shows)."""


@pytest.fixture(scope="module")
def soak_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, int]:
    out = tmp_path_factory.mktemp("soak") / "runs"
    done = subprocess.run([*_murdoch(), "soak", "longterm", *SHORT_SOAK, "--out", str(out)],
                          capture_output=True, text=True, timeout=1500)
    (run_dir,) = out.iterdir()
    return run_dir, done.stdout + done.stderr, done.returncode


@pytest.mark.timeout(1800)
def test_minutes_under_random_faults_keep_every_invariant(
        soak_run: tuple[Path, str, int]) -> None:
    check_soak_run(*soak_run, burst_size=15)
    # the tiny batteries sent a robot to charge
    events = ev.read_events(soak_run[0] / "events.jsonl")
    assert any(e["kind"] == ev.CHARGE_START for e in events)


@pytest.mark.timeout(600)
def test_a_broken_invariant_fails_the_report_with_its_first_counter_example(
        soak_run: tuple[Path, str, int], tmp_path: Path) -> None:
    run_dir, _, _ = soak_run
    broken = tmp_path / "broken"
    shutil.copytree(run_dir, broken)
    events = ev.read_events(broken / "events.jsonl")
    first: dict[str, Any] = next(e for e in events if e["kind"] == ev.TASK_OUTCOME)
    with (broken / "events.jsonl").open("a") as f:
        f.write(json.dumps({"t": events[-1]["t"], "kind": ev.TASK_OUTCOME,
                            "task": first["task"], "outcome": "failed"}) + "\n")
    done = subprocess.run([*_murdoch(), "soak-report", str(broken)], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 3, done.stdout + done.stderr
    assert "BROKEN" in done.stdout and "terminal_states" in done.stdout
    assert first["task"] in done.stdout and "a second terminal state" in done.stdout
    report = json.loads((broken / SOAK_JSON).read_text())
    assert not report["all_held"] and not report["invariants"]["terminal_states"]["held"]
    # the original still holds
    again = subprocess.run([*_murdoch(), "soak-report", str(run_dir)], capture_output=True,
                           text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr


@pytest.mark.timeout(900)
def test_a_soak_whose_invariant_breaks_exits_3(tmp_path: Path) -> None:
    """A bound no reallocation can meet (0 s) on a run that kills a holder."""
    faults = tmp_path / "faults.json"
    faults.write_text(json.dumps([{"t_s": 30, "action": "kill", "robot": "busy"}]))
    out = tmp_path / "runs"
    done = subprocess.run(
        [*_murdoch(), "soak", "longterm", "--sim-hours", "0.025", "--seed", "1",
         "--faults", str(faults), "--realloc-bound", "0", "--out", str(out), "--no-record"],
        capture_output=True, text=True, timeout=800)
    assert done.returncode == 3, (done.stdout + done.stderr)[-3000:]
    assert "soak: invariant reallocation_bound broken" in done.stdout
    (run_dir,) = out.iterdir()
    report = json.loads((run_dir / SOAK_JSON).read_text())
    verdict = report["invariants"]["reallocation_bound"]
    assert not verdict["held"] and verdict["first_counter_example"]["cause"] == "killed"
    assert not report["invariants"]["dead_controller_still"]["checked"]  # no run.mcap


def test_a_bad_fault_file_is_named_without_a_traceback(tmp_path: Path) -> None:
    faults = tmp_path / "faults.json"
    faults.write_text(json.dumps([{"t_s": 30, "action": "kill", "robot": "p42"}]))
    done = subprocess.run([*_murdoch(), "soak", "longterm", "--faults", str(faults),
                           "--out", str(tmp_path / "runs")], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert str(faults) in done.stderr and "p42" in done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "runs").exists()


@pytest.mark.timeout(1800)
def test_boxpush_soaks_its_whole_span_round_after_round_and_repeats(tmp_path: Path) -> None:
    """boxpush ends by itself when the box arrives; soaked, it starts over (the box and the
    robots back at their start, the watch task introduced again) until the span ends, so
    faults after the first arrival act. Two soaks with the same seed write the same events."""
    args = ["soak", "boxpush", "--sim-hours", "0.25", "--seed", "4", "--faults", "random",
            "--kills-per-hour", "20", "--kill-down", "20s-60s", "--freezes-per-hour", "20",
            "--freeze-for", "5s-20s", "--switch-offs", "0", "--bursts", "0",
            # as in the short longterm soak: a quarter hour judges memory on a few samples
            # after the warm-up, too few to tell slow growth from noise at the hourly limit
            "--memory-slope-limit", "30"]
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        done = subprocess.run([*_murdoch(), *args, "--out", str(out)],
                              capture_output=True, text=True, timeout=800)
        assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
        (run_dir,) = out.iterdir()
        runs.append(run_dir)
    run_dir = runs[0]
    report = json.loads((run_dir / SOAK_JSON).read_text())
    assert report["all_held"], report["invariants"]
    events = ev.read_events(run_dir / "events.jsonl")
    assert events[-1]["kind"] == ev.RUN_END and float(events[-1]["t"]) >= 0.25 * 3600 - 1
    goal = json.loads((run_dir / "summary.json").read_text())["goal"]
    assert goal["rounds"] >= 2 and goal["arrivals"] >= 1, goal
    first_arrival = next(float(e["t"]) for e in events if e["kind"] == ev.GOAL_REACHED)
    assert any(e["kind"] in (ev.ROBOT_FAILURE, ev.ROBOT_FREEZE)
               and float(e["t"]) > first_arrival for e in events), "no fault after round 1"
    assert (runs[0] / "events.jsonl").read_bytes() == (runs[1] / "events.jsonl").read_bytes()


def test_an_unknown_world_is_named_without_a_traceback(tmp_path: Path) -> None:
    done = subprocess.run([*_murdoch(), "soak", "longterm", "--world", "atlantis",
                           "--out", str(tmp_path / "runs")], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert "--world" in done.stderr and "atlantis" in done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "runs").exists()
