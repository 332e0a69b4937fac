"""Opt-in (pytest -m soak / make soak): a simulated day of `longterm` under random faults
keeps every invariant, with every process's memory flat; prints the wall time."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest


@pytest.mark.soak
@pytest.mark.timeout(6 * 3600)
def test_a_simulated_day_under_random_faults_loses_nothing(tmp_path: Path) -> None:
    exe = Path(sys.executable).parent / "murdoch"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]
    out = tmp_path / "runs"
    started = time.monotonic()
    done = subprocess.run([*cmd, "soak", "longterm", "--sim-hours", "24", "--seed", "1",
                           "--faults", "random", "--out", str(out)],
                          capture_output=True, text=True)
    wall = time.monotonic() - started
    print(f"\nsoak: 24 simulated hours in {wall:.0f} s of wall time")
    print(done.stdout[-4000:])
    assert done.returncode == 0, done.stderr[-3000:]
    (run_dir,) = out.iterdir()
    report = json.loads((run_dir / "soak.json").read_text())
    assert report["all_held"]
    assert all(v["checked"] for v in report["invariants"].values())
    assert report["sim_hours"] >= 23.99
