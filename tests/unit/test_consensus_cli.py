"""`murdoch allocate` and `murdoch sweep` through click."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from experiments.cli import main


def test_allocate_prints_the_result(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-groups.json"
    r = CliRunner().invoke(main, ["allocate", str(f), "--algorithm", "cbga", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    for key in ("assignment", "start_times", "total_score", "unassigned", "conflict_free",
                "comm_steps", "messages", "bytes"):
        assert key in out
    assert out["conflict_free"] is True
    assert set(out["assignment"]) == {"a1", "a2", "a3", "a4", "a5"}


def test_allocate_engines_print_the_same_result(worlds_dir: Path) -> None:
    f = worlds_dir / "scenarios" / "consensus-small.json"
    outs = []
    for engine in ("compiled", "agents"):
        r = CliRunner().invoke(main, ["allocate", str(f), "--engine", engine, "--json"])
        assert r.exit_code == 0, r.output
        outs.append(json.loads(r.stdout))
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
        r = CliRunner().invoke(main, ["allocate", str(f), "--json", *extra])
        assert r.exit_code == 0, r.output
        outs.append(json.loads(r.stdout))
    assert outs[1]["total_score"] >= outs[0]["total_score"] - 1e-9
    assert outs[1]["conflict_free"] is True
    assert outs[1]["messages"] >= outs[0]["messages"]
    assert "refine" not in outs[0] and "engine_note" not in outs[0]
    assert outs[1]["refine"]["messages"] == outs[1]["messages"] - outs[0]["messages"]
    assert "runs in Python" in outs[1]["engine_note"]


def test_allocate_prints_a_table_and_takes_bundled_names() -> None:
    r = CliRunner().invoke(main, ["allocate", "consensus-small"])
    assert r.exit_code == 0, r.output
    lines = r.stdout.splitlines()
    assert lines[0].startswith("CBBA on consensus-small.json: 4 agents, 8 tasks")
    assert lines[1].split() == ["agent", "tasks", "in", "order", "start", "times", "(s)"]
    a1 = next(line for line in lines if line.startswith("a1 "))
    assert a1.split()[1:5] == ["t4", "t1", "t5", "t8"]  # execution order
    for label in ("total score", "unassigned", "conflict-free", "communication"):
        assert any(line.startswith(label) for line in lines), label
    with_json = CliRunner().invoke(main, ["allocate", "consensus-small.json", "--json"])
    out = json.loads(with_json.stdout)
    assert out["assignment"]["a1"] == ["t4", "t1", "t5", "t8"]
    assert f"{out['total_score']:.2f}" in r.stdout


def test_allocate_names_an_unknown_scenario_and_lists_the_bundled_ones() -> None:
    r = CliRunner().invoke(main, ["allocate", "consensus-tiny"])
    assert r.exit_code == 2
    assert "consensus-tiny" in r.output and "consensus-small" in r.output
    assert "Traceback" not in r.output


def test_kernel_cache_check_finds_the_entry_points_index(tmp_path: Path) -> None:
    from murdoch.consensus_table import COMPILE_NOTE, kernel_cache_warm

    assert not kernel_cache_warm("cbba", [tmp_path])
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "cbga_kernel.run_cbga-914.py311.nbi").write_bytes(b"")
    assert not kernel_cache_warm("cbba", [tmp_path])
    assert kernel_cache_warm("cbga", [tmp_path])
    assert "10-30 s" in COMPILE_NOTE


def test_allocate_says_it_compiles_when_the_cache_is_cold(tmp_path: Path) -> None:
    """With an empty numba cache the first call announces the compilation on stderr (stdout
    still holds only the JSON); the second, from the cache, does not."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    cmd = [sys.executable, "-m", "murdoch", "allocate", "consensus-small", "--json"]
    first = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=280)
    assert first.returncode == 0, first.stderr
    assert "compiling the CBBA kernel once (10-30 s)" in first.stderr
    second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert second.returncode == 0, second.stderr
    assert "compiling" not in second.stderr
    assert json.loads(first.stdout) == json.loads(second.stdout)
