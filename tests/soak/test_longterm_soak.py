"""Opt-in (pytest -m soak / make soak): two simulated hours of the six-robot `longterm` world
under dense random faults keep every invariant, with memory growth under a tight limit. The
default suite runs the same checks on a fifteen-minute soak (tests/integration/test_soak.py)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from soak_checks import check_soak_run, murdoch_command


@pytest.mark.soak
@pytest.mark.timeout(3600)
def test_two_hours_under_random_faults_keep_every_invariant(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    done = subprocess.run(
        [*murdoch_command(), "soak", "longterm", "--sim-hours", "2", "--seed", "4",
         "--faults", "random", "--out", str(out), "--task-interval", "120",
         "--kills-per-hour", "4", "--kill-down", "30s-2m", "--freezes-per-hour", "4",
         "--freeze-for", "5s-40s", "--charger-outages-per-hour", "3",
         "--charger-outage", "3m-6m", "--burst-size", "15", "--memory-every", "2",
         # an hour's window cannot tell slow growth from warming up: the day-long soak
         # keeps the default limit of 2 MiB per simulated hour
         "--memory-slope-limit", "30"],
        capture_output=True, text=True, timeout=3000)
    (run_dir,) = out.iterdir()
    check_soak_run(run_dir, done.stdout + done.stderr, done.returncode, burst_size=15)
