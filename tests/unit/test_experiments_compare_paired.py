"""The seed-by-seed comparison against a reference allocator: pure functions of rows."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest

from experiments.compare import METRICS
from experiments.compare_paired import (
    Paired,
    against_reference,
    format_paired,
    paired,
    write_paired_csv,
)

TWO = (("tasks_completed", "tasks completed"), ("wait_mean_s", "introduction to start (s)"))


def _row(allocator: str, seed: int, completed: float | None, wait: float | None = 10.0,
         ran: bool = True) -> dict[str, Any]:
    return {"allocator": allocator, "seed": seed, "sim_time_s": 3600.0 if ran else None,
            "tasks_completed": completed, "wait_mean_s": wait}


# the seeds differ a lot (20 to 60 tasks); greedy is 2 or 3 above optimal on every one
ROWS = [
    _row("greedy", 1, 22), _row("greedy", 2, 43), _row("greedy", 3, 62),
    _row("optimal", 1, 20), _row("optimal", 2, 40), _row("optimal", 3, 60),
    _row("murdoch", 1, 25), _row("murdoch", 2, 35), _row("murdoch", 3, 62),
]


def test_differences_are_taken_seed_by_seed_in_seed_order() -> None:
    pairs = {(p.allocator, p.metric): p for p in paired(ROWS, TWO)}
    assert set(pairs) == {(a, m) for a in ("greedy", "murdoch") for m, _ in TWO}
    assert pairs["greedy", "tasks_completed"].differences == (2.0, 3.0, 2.0)
    assert pairs["murdoch", "tasks_completed"].differences == (5.0, -5.0, 2.0)
    assert pairs["greedy", "wait_mean_s"].differences == (0.0, 0.0, 0.0)


def test_a_steady_difference_is_told_apart_even_when_the_spreads_over_seeds_overlap() -> None:
    pairs = {(p.allocator, p.metric): p for p in paired(ROWS, TWO)}
    greedy, murdoch = pairs["greedy", "tasks_completed"], pairs["murdoch", "tasks_completed"]
    assert greedy.mean == pytest.approx(7 / 3)
    # t(0.975, 2) = 4.303; stdev of (2, 3, 2) = 0.577
    assert greedy.half_width == pytest.approx(4.3027 * 0.57735 / 3 ** 0.5, rel=1e-3)
    assert greedy.differs and (greedy.above, greedy.below) == (3, 0)
    assert not murdoch.differs and (murdoch.above, murdoch.below) == (2, 1)
    assert not pairs["greedy", "wait_mean_s"].differs


def test_seeds_missing_on_either_side_or_without_a_summary_are_left_out() -> None:
    rows = [*ROWS[3:6], _row("greedy", 1, 21), _row("greedy", 2, None),
            _row("greedy", 3, 70, ran=False), _row("greedy", 4, 80)]
    (p,) = [q for q in paired(rows, TWO) if q.metric == "tasks_completed"]
    assert p.differences == (1.0,)
    assert p.n == 1 and p.half_width is None and not p.differs


def test_without_the_reference_there_is_nothing_to_pair() -> None:
    assert paired([r for r in ROWS if r["allocator"] != "optimal"], TWO) == []
    assert paired(ROWS, TWO, reference="cbga") == []
    assert Paired("x", "tasks_completed", ()).mean is None


def test_the_table_has_a_line_per_metric_and_marks_clear_differences() -> None:
    text = format_paired(paired(ROWS, TWO), TWO)
    lines = text.splitlines()
    assert lines[0].split() == ["minus", "optimal,", "same", "seed", "greedy", "murdoch"]
    assert lines[1].startswith("tasks completed")
    assert "+2.3 ± 1.4 * (3↑ 0↓)" in lines[1]
    assert "+0.7 ± " in lines[1] and "(2↑ 1↓)" in lines[1]
    assert "*" not in lines[2]


def test_the_csv_holds_every_pair_and_its_differences(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    write_paired_csv(paired(ROWS, TWO), path)
    with path.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    first = rows[0]
    assert (first["allocator"], first["reference"], first["metric"]) == (
        "greedy", "optimal", "tasks_completed")
    assert first["differences"] == "2 3 2" and first["seeds_above"] == "3"


def test_against_reference_writes_the_csv_and_figure_and_returns_the_table(
        tmp_path: Path) -> None:
    rows = [{**r, **dict.fromkeys((k for k, _ in METRICS if k not in r), 1.0)} for r in ROWS]
    table = against_reference(rows, METRICS, tmp_path, "test")
    assert table is not None and "tasks completed" in table
    assert (tmp_path / "comparison-paired.csv").stat().st_size > 0
    assert (tmp_path / "comparison-paired.png").read_bytes()[:4] == b"\x89PNG"
    empty = tmp_path / "none"
    empty.mkdir()
    assert against_reference(rows[:3], METRICS, empty, "test") is None
    assert list(empty.iterdir()) == []
