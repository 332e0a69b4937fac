"""The load sweep's rows, means, table and the rate that gives a target count (pure)."""

from __future__ import annotations

from pathlib import Path

import pytest

from experiments.sweep_longterm import (
    Job,
    by_interval,
    format_table,
    plot_sweep,
    rate_for,
    row_of,
    write_csv,
)


def summary(executed: int, first: int, trips: int, sim_s: float = 3600.0) -> dict:
    return {
        "sim_time_s": sim_s,
        "tasks": {"introduced": executed + 2, "executed": executed, "failed": 2,
                  "reallocations": 1, "first_attempt_unallocatable": first,
                  "then_allocated": first - 1, "unachievable_after_backoff": 1},
        "waits_s": {"mean": 3.0, "median": 1.5, "p95": 9.0, "never_awarded": 1},
        "charging_trips": trips, "wall_time_s": 50.0, "events_sha256": "ab",
        "robot_failures": 0,
    }


def test_rows_scale_to_three_hours_and_average_over_seeds(tmp_path: Path) -> None:
    rows = [row_of(Job(240.0, 1), summary(10, 2, 3), 0, tmp_path),
            row_of(Job(240.0, 2), summary(14, 4, 5), 0, tmp_path),
            row_of(Job(120.0, 1), summary(20, 6, 6), 0, tmp_path),
            row_of(Job(120.0, 2), None, 1, None)]
    assert rows[0]["offered_per_h"] == 15.0 and rows[0]["executed_per_3h"] == 30.0
    assert rows[3]["executed"] is None and rows[3]["exit_code"] == 1
    means = by_interval(rows)
    assert [m["task_interval_s"] for m in means] == [240.0, 120.0]  # lowest load first
    assert means[0]["runs"] == 2 and means[0]["executed"] == 12.0
    assert means[0]["charging_trips"] == 4.0 and means[1]["runs"] == 1
    table = format_table(means)
    assert "1st no bid" in table.splitlines()[0] and len(table.splitlines()) == 3
    write_csv(rows, tmp_path / "sweep.csv")
    assert (tmp_path / "sweep.csv").read_text().count("\n") == 5
    assert plot_sweep(rows, means, tmp_path / "sweep.png").stat().st_size > 10_000


def test_rate_for_interpolates_between_the_bracketing_loads() -> None:
    means = [{"offered_per_h": 15.0, "executed_per_3h": 40.0},
             {"offered_per_h": 20.0, "executed_per_3h": 50.0},
             {"offered_per_h": 30.0, "executed_per_3h": 60.0}]
    assert rate_for(means, 49) == pytest.approx(19.5)
    assert rate_for(means, 50) == 20.0
    assert rate_for(means, 70) is None
    assert rate_for([], 49) is None
