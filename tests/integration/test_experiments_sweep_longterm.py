"""`murdoch sweep-longterm` end to end: real runs in parallel, CSV, table, plots."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(400)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def test_a_small_sweep_writes_rows_table_and_plots(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    proc = subprocess.run(
        [*_murdoch(), "sweep-longterm", "--intervals", "15,45", "--seeds", "3", "--until",
         "75s", "--jobs", "2", "--out", str(out)],
        capture_output=True, text=True, timeout=380, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    with (out / "sweep.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [(r["task_interval_s"], r["seed"]) for r in rows] == [("45.0", "3"), ("15.0", "3")]
    for row in rows:
        assert row["exit_code"] == "0" and row["robot_failures"] == "0"
        summary = json.loads((Path(row["run_dir"]) / "summary.json").read_text())
        assert int(row["executed"]) == summary["tasks"]["executed"]
        assert int(row["first_attempt_unallocatable"]) == (
            summary["tasks"]["first_attempt_unallocatable"])
        assert json.loads((Path(row["run_dir"]) / "config.json").read_text())[
            "task_interval_s"] == float(row["task_interval_s"])
    # more tasks offered, more introduced
    assert int(rows[1]["introduced"]) > int(rows[0]["introduced"])
    assert "tasks/h" in proc.stdout and "1st no bid" in proc.stdout
    assert (out / "sweep.png").stat().st_size > 10_000
    means = json.loads((out / "sweep-means.json").read_text())
    assert [m["offered_per_h"] for m in means] == [80.0, 240.0]


def test_bad_options_are_refused_before_anything_runs(tmp_path: Path) -> None:
    for args, needle in ((["--intervals", "0,60"], "--intervals"),
                         (["--seeds", "a"], "--seeds"),
                         (["--metric", "charisma"], "--metric")):
        proc = subprocess.run([*_murdoch(), "sweep-longterm", *args, "--out", str(tmp_path)],
                              capture_output=True, text=True, timeout=60, check=False)
        assert proc.returncode == 2, proc.stderr
        assert needle in proc.stderr and "Traceback" not in proc.stderr
    assert not list(tmp_path.iterdir())
