"""Every death is recorded; a fault that finds nothing says so; impossible runs stop at once."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from experiments import events as ev

pytestmark = pytest.mark.timeout(300)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


@pytest.mark.parametrize("per_process", ["1", "auto"])
def test_a_robot_killed_from_outside_the_schedule_is_recorded_with_its_exit_code(
    tmp_path: Path, per_process: str,
) -> None:
    """A process per robot: p2's own process is killed, p2 alone fails. ``auto`` on this
    machine: the team shares a host process, whose death is every robot's; the run goes on
    without a team to its end."""
    out = tmp_path / "runs"
    run = subprocess.Popen([*_murdoch(), "run", "longterm", "--until", "400s", "--seed", "3",
                            "--no-replay", "--no-plots", "--robots-per-process", per_process,
                            "--out", str(out)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    victim_pid = None
    try:
        deadline = time.monotonic() + 120.0
        while victim_pid is None and time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.2)
            for notes in out.glob("*/processes.jsonl"):
                for line in notes.read_text().splitlines():
                    note = json.loads(line)
                    if note.get("what") == "started" and note.get("robot") == "p2":
                        victim_pid = int(note["pid"])
        assert victim_pid is not None, "the run never started p2"
        # wait until the run is under way (30 simulated seconds), then kill p2's process
        # outside the fault schedule
        (events_file,) = out.glob("*/events.jsonl")
        while time.monotonic() < deadline and run.poll() is None and not any(
                json.loads(line)["t"] >= 30.0 for line in events_file.read_text().splitlines()
                if line.endswith("}")):
            time.sleep(0.2)
        os.kill(victim_pid, signal.SIGKILL)
        stdout, _ = run.communicate(timeout=240)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait(10)
    assert run.returncode == 0, stdout[-2000:]
    (run_dir,) = out.iterdir()
    config = json.loads((run_dir / "config.json").read_text())
    hosts = config.get("robot_hosts", [])
    sharing = next((h["robots"] for h in hosts if "p2" in h["robots"]), ["p2"])
    # auto: seven members over one host per CPU left to the robots (one host on two CPUs)
    assert (len(sharing) > 1) == (per_process == "auto" and len(os.sched_getaffinity(0)) < 8)
    events = ev.read_events(run_dir / "events.jsonl")
    deaths = [e for e in events if e["kind"] == ev.ROBOT_FAILURE]
    assert sorted(e["robot"] for e in deaths) == sorted(sharing)
    assert all(e["reason"] == "exited" and e["exit_code"] == -signal.SIGKILL for e in deaths)
    assert events[-1]["kind"] == ev.RUN_END and float(events[-1]["t"]) >= 400 - 1
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["robot_failures"] == len(sharing)
    assert summary["invariant_terminal_states"]["holds"]


def test_kill_busy_with_nobody_busy_is_recorded_as_skipped(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "boxpush", "--until", "5s", "--seed", "2", "--kill", "busy@0.5s",
         "--restart", "busy@2s", "--no-replay", "--no-plots", "--out", str(out)],
        capture_output=True, text=True, timeout=200, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run_dir,) = out.iterdir()
    events = ev.read_events(run_dir / "events.jsonl")
    skipped = [(e["t"], e["action"], e["reason"]) for e in events
               if e["kind"] == ev.FAULT_SKIPPED]
    assert skipped == [(0.5, "kill", "no robot holds a task"),
                       (2.0, "restart", "no robot was killed as busy")]
    assert not [e for e in events if e["kind"] == ev.ROBOT_FAILURE]


def test_a_world_without_a_mobile_robot_is_refused_before_anything_starts(
    tmp_path: Path,
) -> None:
    source = (Path(__file__).parents[2] / "worlds" / "simple.toml").read_text()
    head, robots = source.split("[[robots]]", 1)
    fixed = "[[robots]]" + robots.replace("[robots.position2d]\nmax_speed = 0.5\n", "")
    world = tmp_path / "still.toml"
    world.write_text(head + fixed)
    out = tmp_path / "runs"
    proc = subprocess.run([*_murdoch(), "run", "longterm", "--world", str(world), "--until",
                           "60s", "--out", str(out)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 2
    assert "no mobile robot" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists() or not any(out.iterdir())
