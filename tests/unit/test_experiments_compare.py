"""The comparison's figures and table: pure functions of events, summaries and rows."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click
import pytest

from experiments.compare import (
    COLUMNS,
    METRICS,
    Job,
    by_allocator,
    format_table,
    mean_std,
    parse_allocators,
    reallocations_after_kills,
    rows_in_order,
    run_row,
    start_waits,
    user_outcomes,
    write_csv,
)


def _e(t: float, kind: str, **fields: Any) -> dict[str, Any]:
    return {"t": t, "kind": kind, **fields}


EVENTS = [
    _e(0.0, "run_start", experiment="longterm", seed=1),
    _e(5.0, "task_introduced", task="a", task_kind="cleanup", source="user"),
    _e(6.0, "award", task="a", robot="p3"),
    _e(6.5, "robot_task", robot="p3", phase="start", task="a"),
    _e(10.0, "task_introduced", task="group-1", task_kind="watch-object-pair",
       source="user", group=True),
    _e(10.0, "task_introduced", task="m1", task_kind="watch-object-side", source="group",
       parent="group-1"),
    _e(10.0, "task_introduced", task="m2", task_kind="watch-object-side", source="group",
       parent="group-1"),
    _e(11.2, "robot_task", robot="p1", phase="start", task="m1"),
    _e(14.0, "robot_task", robot="p2", phase="start", task="m2"),
    _e(20.0, "robot_failure", robot="p3", reason="killed"),
    _e(31.0, "reallocation", task="a", from_robot="p3", reason="silent"),
    _e(32.0, "reallocation", task="x", from_robot="p1", reason="declined"),
    _e(33.0, "robot_task", robot="p4", phase="start", task="a"),
    _e(40.0, "task_outcome", task="group-1", outcome="completed", robots=["p1", "p2"]),
    _e(45.0, "robot_restart", robot="p3"),
    _e(50.0, "reallocation", task="y", from_robot="p3", reason="declined"),
    _e(60.0, "task_introduced", task="b", task_kind="sentry-duty", source="user"),
    _e(90.0, "task_outcome", task="b", outcome="unachievable", reason="unachievable"),
    _e(99.0, "task_outcome", task="m1", outcome="completed", robot="p1"),
    _e(99.0, "task_outcome", task="m2", outcome="completed", robot="p2"),
    _e(120.0, "task_outcome", task="a", outcome="failed", reason="run ended"),
]


def test_start_waits_take_the_first_start_and_a_group_waits_for_its_last_member() -> None:
    waits = start_waits(EVENTS)
    # a: 6.5 - 5 (its restart on p4 after the kill does not count); group-1: 14 - 10; b never
    assert waits == pytest.approx([1.5, 4.0])


def test_a_group_taken_whole_starts_when_its_last_robot_does() -> None:
    params = {"required": 2, "members": [{"kind": "watch-object-side"}] * 2}
    events = [_e(10.0, "task_introduced", task="group-1", task_kind="watch-object-pair",
                 source="user", group=True),
              _e(10.0, "task_introduced", task="u.1", task_kind="watch-object-pair",
                 source="group", parent="group-1", params=params),
              _e(12.0, "robot_task", robot="p1", phase="start", task="u.1"),
              _e(12.5, "robot_task", robot="p1", phase="start", task="u.1"),
              _e(17.0, "robot_task", robot="p2", phase="start", task="u.1")]
    assert start_waits(events) == pytest.approx([7.0])
    assert start_waits(events[:-1]) == []  # one robot of two: the group has not started


def test_reallocations_after_kills_count_only_tasks_taken_from_a_robot_that_is_down() -> None:
    assert reallocations_after_kills(EVENTS) == 1  # x from p1 (up), y after p3's restart


def test_user_outcomes_count_group_tasks_once_and_leave_their_members_out() -> None:
    assert user_outcomes(EVENTS) == {"group-1": "completed", "b": "unachievable",
                                     "a": "open_at_end"}


def test_a_row_from_a_summary_and_its_events() -> None:
    summary = {"sim_time_s": 120.0, "messages": {"total": 90, "total_bytes": 9000},
               "distance_m": {"by_robot": {"p1": 3.0}, "total": 12.5},
               "group_tasks_completed": 1, "wall_time_s": 30.0, "events_sha256": "ab"}
    row = run_row(Job("murdoch", 3), summary, EVENTS, 0, Path("/r"))
    assert set(row) == set(COLUMNS)
    assert row["tasks_introduced"] == 3 and row["tasks_completed"] == 1
    assert row["unachievable"] == 1 and row["group_tasks_completed"] == 1
    assert row["messages_per_task"] == 30.0 and row["bytes_per_task"] == 3000.0
    assert row["wait_mean_s"] == 2.75 and row["distance_m"] == 12.5
    assert row["reallocations_after_kills"] == 1 and row["run_dir"] == "/r"


def test_a_run_without_a_summary_has_no_figures() -> None:
    row = run_row(Job("cbga", 2), None, [], 1, None)
    assert row["allocator"] == "cbga" and row["exit_code"] == 1
    assert all(row[k] is None for k, _ in METRICS)


class _Run:
    """A run under way that is already over: its row, or the error it raised."""

    def __init__(self, job: Job, log: list[str], error: Exception | None) -> None:
        self.job, self.log, self.error = job, log, error

    def result(self) -> dict[str, Any]:
        self.log.append(f"result {self.job.label()}")
        if self.error is not None:
            raise self.error
        return run_row(self.job, {"sim_time_s": 60.0}, [], 0, Path(self.job.label()))


def test_rows_come_in_job_order_and_a_run_that_raised_gets_an_error_row() -> None:
    jobs = [Job("murdoch", 1), Job("cbba", 1), Job("murdoch", 2)]
    log: list[str] = []
    seen: list[str] = []

    def submit(job: Job) -> _Run:
        log.append(f"submit {job.label()}")
        return _Run(job, log, ConnectionError("worker lost") if job.seed == 1
                    and job.allocator == "cbba" else None)

    rows = rows_in_order(jobs, submit, lambda row: seen.append(str(row["allocator"])))
    # every run is under way before the first row is taken
    assert log[:3] == [f"submit {j.label()}" for j in jobs]
    assert log[3:] == [f"result {j.label()}" for j in jobs]
    assert [(r["allocator"], r["seed"]) for r in rows] == [(j.allocator, j.seed) for j in jobs]
    assert seen == ["murdoch", "cbba", "murdoch"]
    assert rows[0]["exit_code"] == 0 and rows[0]["error"] is None
    lost = rows[1]
    assert set(lost) == set(COLUMNS) and lost["exit_code"] is None
    assert lost["error"] == "ConnectionError: worker lost" and lost["run_dir"] is None
    assert all(lost[k] is None for k, _ in METRICS) and lost["sim_time_s"] is None
    assert rows[2]["run_dir"] == "murdoch-s2"


def test_mean_and_sample_standard_deviation() -> None:
    mean, std, n = mean_std([2, 4, 4, 4, 5, 5, 7, 9])
    assert (mean, n) == (5.0, 8)
    assert std == pytest.approx(math.sqrt(32 / 7))
    assert mean_std([3.0]) == (3.0, 0.0, 1)
    assert mean_std([None, float("nan")]) == (None, None, 0)
    assert mean_std([None, 1.0, 3.0]) == (2.0, pytest.approx(math.sqrt(2)), 2)


def _row(allocator: str, seed: int, completed: int | None, **more: Any) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(allocator=allocator, seed=seed, tasks_completed=completed,
               sim_time_s=None if completed is None else 600.0, **more)
    return row


def test_by_allocator_groups_rows_in_the_order_given_and_skips_runs_without_a_summary() -> None:
    rows = [_row("cbga", 1, 10), _row("murdoch", 1, 8), _row("murdoch", 2, 12),
            _row("murdoch", 3, None), _row("cbga", 2, 14)]
    stats = by_allocator(rows, ["murdoch", "cbga"])
    assert [s["allocator"] for s in stats] == ["murdoch", "cbga"]
    assert stats[0]["runs"] == 2 and stats[1]["runs"] == 2
    assert stats[0]["tasks_completed"] == (10.0, pytest.approx(math.sqrt(8)))
    assert stats[1]["tasks_completed"] == (12.0, pytest.approx(math.sqrt(8)))
    assert stats[0]["unachievable"] == (None, None)


def test_the_table_has_a_line_per_metric_and_a_column_per_allocator() -> None:
    stats = by_allocator([_row("murdoch", 1, 8, distance_m=120.4),
                          _row("murdoch", 2, 12, distance_m=130.6),
                          _row("cbba", 1, 9, distance_m=99.0)])
    lines = format_table(stats).splitlines()
    assert len(lines) == 1 + len(METRICS)
    assert "murdoch (2 runs)" in lines[0] and "cbba (1 run)" in lines[0]
    assert lines[0].index("murdoch") < lines[0].index("cbba")
    completed = next(line for line in lines if line.startswith("tasks completed"))
    assert "10.0 ± 2.8" in completed and "9.00 ± 0.00" in completed
    distance = next(line for line in lines if line.startswith("distance driven"))
    assert "126 ± 7" in distance and "99.0 ± 0.0" in distance
    unachievable = next(line for line in lines if line.startswith("unachievable"))
    assert unachievable.split()[-1] == "-"


def test_the_csv_has_every_column(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    write_csv([_row("murdoch", 1, 3)], path)
    head, line = path.read_text().splitlines()
    assert head.split(",") == list(COLUMNS)
    assert line.startswith("murdoch,1,")


def test_allocator_names_are_checked() -> None:
    assert parse_allocators("murdoch, cbga,murdoch") == ["murdoch", "cbga"]
    with pytest.raises(click.BadParameter, match="among murdoch, cbba, cbga"):
        parse_allocators("murdoch,auction")
    with pytest.raises(click.BadParameter):
        parse_allocators(" , ")


def test_distance_driven_sums_each_robots_steps_and_leaves_out_placements() -> None:
    from experiments.report import path_lengths

    frames = [{"t": 0.0, "bodies": {"p1": [0.0, 0.0, 0.0], "box": [5.0, 5.0, 0.0]}},
              {"t": 0.5, "bodies": {"p1": [0.3, 0.4, 0.0], "p2": [1.0, 1.0, 0.0]}},
              {"t": 1.0, "bodies": {"p1": [0.3, 0.4, 0.0], "p2": [1.0, 1.25, 0.0],
                                    "box": [9.0, 9.0, 0.0]}},
              {"t": 1.5, "bodies": {"p1": [4.3, 0.4, 0.0]}}]  # p1 placed 4 m away
    assert path_lengths(frames, ["p1", "p2", "p3"]) == {"p1": 0.5, "p2": 0.25, "p3": 0.0}
