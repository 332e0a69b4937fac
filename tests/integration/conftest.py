"""Runs that several integration tests read: each made once per session.

A lockstep run is a pure function of its world, seed and options, so a test that only reads
a run directory can share one with the others that need the same run. Each shared run is
made by the options the tests name here; a test that needs another run makes its own.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

LONGTERM_KILLED_WINNER = [
    "run", "longterm", "--until", "150s", "--task-interval", "25", "--seed", "4",
    "--kill", "busy@45s", "--restart", "busy@90s", "--robots-per-process", "1"]
"""150 simulated seconds of longterm whose busy robot is killed at 45 s and restarted at 90 s
(recorded, with replay.html), every robot a process of its own (the default on two CPUs puts
the team in one host process; this is the twin the hosted runs are held to)."""

BOXPUSH_SWITCHED = [
    "run", "boxpush", "--until", "90s", "--seed", "2", "--switch-off", "pusher1@30s",
    "--switch-on", "pusher1@60s", "--no-replay", "--no-plots"]
"""90 simulated seconds of boxpush with pusher1 switched off at 30 s and on at 60 s, every
robot writing a profile of its loop (MURDOCH_ROBOT_PROFILE_DIR); no plots drawn."""


def murdoch_command() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


@dataclass(frozen=True)
class SharedRun:
    args: tuple[str, ...]
    """The murdoch command line that made it, less --out."""
    proc: subprocess.CompletedProcess[str]
    run: Path
    """The run directory."""
    profiles: Path | None = None
    """Where the robots wrote their profiles, if asked to."""


def _made(args: list[str], root: Path, env: dict[str, str] | None = None) -> SharedRun:
    out = root / "runs"
    proc = subprocess.run([*murdoch_command(), *args, "--out", str(out)], capture_output=True,
                          text=True, timeout=560, check=False, env=env)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    return SharedRun(tuple(args), proc, run)


@pytest.fixture(scope="session")
def longterm_killed_winner_run(tmp_path_factory: pytest.TempPathFactory) -> SharedRun:
    return _made(LONGTERM_KILLED_WINNER, tmp_path_factory.mktemp("longterm-killed-winner"))


@pytest.fixture(scope="session")
def boxpush_switched_run(tmp_path_factory: pytest.TempPathFactory) -> SharedRun:
    root = tmp_path_factory.mktemp("boxpush-switched")
    profiles = root / "profiles"
    profiles.mkdir()
    made = _made(BOXPUSH_SWITCHED, root,
                 env={**os.environ, "MURDOCH_ROBOT_PROFILE_DIR": str(profiles)})
    return SharedRun(made.args, made.proc, made.run, profiles)
