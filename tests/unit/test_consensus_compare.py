"""Paired differences between sweep runs (`compare.py`, `murdoch sweep-compare`)."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

from murdoch.consensus.compare import against_first, between, markdown
from murdoch.consensus_cli import sweep as sweep_command
from murdoch.consensus_cli import sweep_compare


def _row(variant: str, run: int, score: float, agents: int = 4) -> dict[str, str]:
    return {"experiment": "fig7", "variant": variant, "n_agents": str(agents),
            "run": str(run), "score": str(score)}


def test_against_first_pairs_runs_and_gives_standard_errors() -> None:
    rows = [_row("CBGA", 0, 10), _row("CBGA", 1, 20), _row("CBGA", 2, 30),
            _row("quitting", 0, 12), _row("quitting", 1, 20), _row("quitting", 2, 36),
            _row("quitting", 3, 99)]  # run 3 has no partner: left out
    (p,) = against_first(rows, "score", {"fig7": ["CBGA", "quitting"]})
    assert (p.variant, p.reference, p.runs) == ("quitting", "CBGA", 3)
    assert p.mean == pytest.approx(20.0)
    assert p.diff == pytest.approx(8 / 3)  # differences 2, 0, 6
    assert p.se == pytest.approx(math.sqrt(((2 - 8 / 3) ** 2 + (8 / 3) ** 2
                                            + (6 - 8 / 3) ** 2) / 2 / 3))
    assert (p.up, p.down, p.same) == (2, 0, 1)
    assert "| fig7 | quitting | CBGA | 4 | score | 3 |" in markdown([p])
    assert markdown([p], agents=[10]).count("\n") == 2  # header only


def test_between_sweeps() -> None:
    base = [_row("CBGA", r, 10.0 * r) for r in range(4)]
    other = [_row("CBGA", r, 10.0 * r - 1) for r in range(4)]
    (p,) = between(base, other, "score", reference="discount")
    assert (p.diff, p.se, p.down, p.reference) == (-1.0, 0.0, 4, "discount")


def test_sweep_compare_command(tmp_path) -> None:  # type: ignore[no-untyped-def]
    runner = CliRunner()
    dirs = []
    for cost in ("discount", "paper"):
        out = tmp_path / cost
        res = runner.invoke(sweep_command, ["--experiment", "fig7", "--agents", "4",
                                            "--runs", "2", "--jobs", "1", "--cost", cost,
                                            "--out", str(out)])
        assert res.exit_code == 0, res.output
        dirs.append(str(out))
    res = runner.invoke(sweep_compare, [dirs[0], "--metric", "pairwise_steps"])
    assert res.exit_code == 0, res.output
    assert "| fig7 | quitting | CBGA | 4 | pairwise_steps | 2 |" in res.output
    res = runner.invoke(sweep_compare, dirs)
    assert res.exit_code == 0, res.output
    assert "| fig7 | CBGA | discount | 4 | score | 2 |" in res.output
    res = runner.invoke(sweep_compare, [str(tmp_path)])
    assert res.exit_code != 0 and "no runs.csv" in res.output
