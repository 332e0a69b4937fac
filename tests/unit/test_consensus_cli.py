"""`murdoch allocate` and `murdoch sweep` through click."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from experiments.cli import main


def test_allocate_prints_the_result(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-groups.json"
    r = CliRunner().invoke(main, ["allocate", str(f), "--algorithm", "cbga"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    for key in ("assignment", "start_times", "total_score", "unassigned", "conflict_free",
                "comm_steps", "messages", "bytes"):
        assert key in out
    assert out["conflict_free"] is True
    assert set(out["assignment"]) == {"a1", "a2", "a3", "a4", "a5"}


def test_allocate_engines_print_the_same_result(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-small.json"
    outs = []
    for engine in ("compiled", "agents"):
        r = CliRunner().invoke(main, ["allocate", str(f), "--engine", engine])
        assert r.exit_code == 0, r.output
        outs.append(json.loads(r.output))
    assert outs[0] == outs[1]
    assert outs[0]["assignment"] and outs[0]["conflict_free"] is True


def test_allocate_cbba_refuses_group_tasks(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-groups.json"
    r = CliRunner().invoke(main, ["allocate", str(f), "--algorithm", "cbba"])
    assert r.exit_code != 0
    assert "single-agent" in r.output


def test_allocate_reports_bad_files(tmp_path: Path) -> None:
    f = tmp_path / "bad.json"
    f.write_text(json.dumps({"agents": [{"id": "a", "pos": [0]}], "tasks": []}))
    r = CliRunner().invoke(main, ["allocate", str(f)])
    assert r.exit_code != 0
    assert "agents[0].pos" in r.output and "bad.json" in r.output


def test_sweep_writes_table_and_figures(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    r = CliRunner().invoke(main, ["sweep", "--experiment", "fig5", "--agents", "1-2",
                                  "--runs", "2", "--seed", "4", "--jobs", "1",
                                  "--out", str(out)])
    assert r.exit_code == 0, r.output
    table = (out / "results.md").read_text()
    assert "CBBA single-agent" in table and "CBGA two-agent" in table and " ± " in table
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["rows"]) == 6  # 3 variants x 2 agent counts
    assert (out / "fig5.png").stat().st_size > 1000
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + 12


def test_allocate_refine_prints_a_result_at_least_as_good(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-small.json"
    outs = []
    for extra in ([], ["--refine", "--refine-seed", "3"]):
        r = CliRunner().invoke(main, ["allocate", str(f), *extra])
        assert r.exit_code == 0, r.output
        outs.append(json.loads(r.output))
    assert outs[1]["total_score"] >= outs[0]["total_score"] - 1e-9
    assert outs[1]["conflict_free"] is True
    assert outs[1]["messages"] >= outs[0]["messages"]
    assert "refine" not in outs[0] and "engine_note" not in outs[0]
    assert outs[1]["refine"]["messages"] == outs[1]["messages"] - outs[0]["messages"]
    assert "runs in Python" in outs[1]["engine_note"]
