"""`murdoch compare longterm` end to end: real runs in parallel, group tasks, a kill and a
restart in every run, then the CSV, the figure and the table."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.compare import COLUMNS, METRICS

pytestmark = pytest.mark.timeout(500)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def test_compare_runs_every_seed_and_writes_csv_figure_and_table(tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    proc = subprocess.run(
        [*_murdoch(), "compare", "longterm", "--allocators", "murdoch", "--seeds", "1-2",
         "--until", "4m", "--task-interval", "50", "--group-tasks", "0.5",
         "--kill", "busy@60s", "--restart", "busy@150s", "--jobs", "2", "--no-plots",
         "--out", str(out)],
        capture_output=True, text=True, timeout=480, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    with (out / "comparison.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(COLUMNS)
    assert [(r["allocator"], r["seed"]) for r in rows] == [("murdoch", "1"), ("murdoch", "2")]
    groups_completed = 0
    for row in rows:
        assert row["exit_code"] == "0"
        run = Path(row["run_dir"])
        summary = json.loads((run / "summary.json").read_text())
        config = json.loads((run / "config.json").read_text())
        assert summary["allocator"] == config["allocator"] == "murdoch"
        assert config["group_task_rate"] == 0.5 and config["kills"] == ["busy@60s"]
        # MURDOCH's robots are started as they always were
        assert all("--allocator" not in p["args"] for p in config["processes"])
        assert summary["invariant_terminal_states"]["holds"]
        assert summary["robot_failures"] == 1 and summary["robot_restarts"] == 1
        group = summary["group_tasks"]
        assert group["introduced"] >= 1
        assert group["introduced"] == (group["completed"] + group["failed"]
                                       + group["unachievable"] + group["open_at_end"])
        assert int(row["group_tasks_completed"]) == summary["group_tasks_completed"]
        assert float(row["distance_m"]) == pytest.approx(summary["distance_m"]["total"])
        assert summary["distance_m"]["total"] > 0
        assert float(row["messages_per_task"]) == pytest.approx(
            summary["messages"]["total"] / int(row["tasks_introduced"]), abs=1e-3)
        groups_completed += summary["group_tasks_completed"]
        events = [json.loads(line) for line in (run / "events.jsonl").open()]
        for done in (e for e in events if e["kind"] == "task_outcome"
                     and str(e["task"]).startswith("group-") and e["outcome"] == "completed"):
            assert len(set(done["robots"])) == 2  # two robots, each at its own spot
    # the two seeds between them complete group tasks (in lockstep each run repeats exactly)
    assert groups_completed >= 1
    lines = proc.stdout.splitlines()
    head = next(i for i, line in enumerate(lines) if "murdoch (2 runs)" in line)
    table = lines[head + 1: head + 1 + len(METRICS)]
    assert [line.split("  ")[0].strip() for line in table] == [label for _, label in METRICS]
    assert all("±" in line for line in table)
    png = out / "comparison.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_bad_options_are_refused_before_anything_runs(tmp_path: Path) -> None:
    for args, needle in ((["--allocators", "murdoch,auction"], "--allocators"),
                         (["--seeds", "a"], "--seeds"),
                         (["--group-tasks", "2"], "--group-tasks"),
                         (["--kill", "p9@1m"], "p9"),
                         (["--kill", "p1@4h", "--until", "1h"], "p1@4h"),
                         (["--metric", "charisma"], "--metric"),
                         (["--sim-hours", "-1"], "--sim-hours"),
                         (["--world", "nowhere"], "nowhere")):
        proc = subprocess.run([*_murdoch(), "compare", "longterm", *args, "--out",
                               str(tmp_path / "c")],
                              capture_output=True, text=True, timeout=60, check=False)
        assert proc.returncode == 2, (args, proc.stdout, proc.stderr)
        assert needle in proc.stderr and "Traceback" not in proc.stderr
    assert not list(tmp_path.iterdir())


def test_resume_reuses_finished_runs_made_with_the_same_options(tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    args = [*_murdoch(), "compare", "longterm", "--seeds", "1", "--until", "60s",
            "--task-interval", "30", "--jobs", "2", "--out", str(out)]

    def compare(*more: str) -> subprocess.CompletedProcess[str]:
        proc = subprocess.run([*args, *more], capture_output=True, text=True, timeout=400,
                              check=False)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        return proc

    def rows() -> list[dict[str, str]]:
        with (out / "comparison.csv").open() as f:
            return list(csv.DictReader(f))

    compare("--allocators", "murdoch")
    (first,) = rows()
    # the comparison gains an allocator: the finished run stands, only the new one is made
    # (its plots left out: how a run's output is drawn is not what it ran)
    proc = compare("--allocators", "murdoch,cbga", "--resume", "--no-plots")
    assert "murdoch-s1: reused" in proc.stdout and "cbga-s1: reused" not in proc.stdout
    again = rows()
    assert again[0] == first and again[1]["allocator"] == "cbga"
    assert again[1]["exit_code"] == "0" and again[1]["events_sha256"]
    assert len([p for p in (out / "murdoch-s1").iterdir() if p.is_dir()]) == 1
    assert list(out.glob("murdoch-s1/*/plots/tasks.png"))
    assert list(out.glob("cbga-s1/*/plots")) and not list(out.glob("cbga-s1/*/plots/*.png"))
    assert not (out / "comparison-paired.csv").exists()  # no optimal: nothing to pair with
    # with the exact central assignment, every other allocator is also set against it
    proc = compare("--allocators", "murdoch,cbga,optimal", "--resume", "--no-plots")
    assert "murdoch-s1: reused" in proc.stdout and "cbga-s1: reused" in proc.stdout
    assert "minus optimal, same seed" in proc.stdout
    with (out / "comparison-paired.csv").open() as f:
        pairs = list(csv.DictReader(f))
    assert {p["allocator"] for p in pairs} == {"murdoch", "cbga"}
    completed = {p["allocator"]: p for p in pairs if p["metric"] == "tasks_completed"}
    by_allocator = {r["allocator"]: r for r in rows()}
    for name in ("murdoch", "cbga"):
        want = (int(by_allocator[name]["tasks_completed"])
                - int(by_allocator["optimal"]["tasks_completed"]))
        assert completed[name]["seeds"] == "1" and completed[name]["differences"] == f"{want:g}"
    assert (out / "comparison-paired.png").read_bytes()[:4] == b"\x89PNG"
