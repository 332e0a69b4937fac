"""`murdoch run --transport zenoh`: the same lockstep run as on multicast, event for event."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from experiments import events as ev
from experiments.summary import terminal_state_problems

pytest.importorskip("zenoh", reason="the zenoh extra (eclipse-zenoh) is not installed")
pytestmark = pytest.mark.timeout(300)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(out: Path, *extra: str) -> Path:
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--until", "40s", "--task-interval", "8",
         "--seed", "5", "--no-replay", "--no-plots", "--out", str(out), *extra],
        capture_output=True, text=True, timeout=280, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    (run,) = out.iterdir()
    return run


def test_a_lockstep_run_over_zenoh_writes_the_multicast_runs_events(tmp_path: Path) -> None:
    over_zenoh = _run(tmp_path / "zenoh", "--transport", "zenoh")
    over_multicast = _run(tmp_path / "multicast")
    config = json.loads((over_zenoh / "config.json").read_text())
    assert config["transport"] == "zenoh" and config["lockstep"] is True
    args = config["processes"][0]["args"]
    assert args[args.index("--transport") + 1] == "zenoh"
    assert args[args.index("--zenoh-endpoint") + 1].startswith("tcp/127.0.0.1:")
    summaries = [json.loads((r / "summary.json").read_text())
                 for r in (over_zenoh, over_multicast)]
    assert summaries[0]["events_sha256"] == summaries[1]["events_sha256"]
    events = ev.read_events(over_zenoh / "events.jsonl")
    assert not any(terminal_state_problems(events).values())
    assert summaries[0]["tasks"]["introduced"] >= 2
    assert {"announce", "bid", "award"} <= set(summaries[0]["messages"]["by_kind"])


def test_robots_sharing_a_process_over_zenoh_write_the_same_events(tmp_path: Path) -> None:
    shared = _run(tmp_path / "shared", "--transport", "zenoh", "--robots-per-process", "3")
    alone = _run(tmp_path / "alone", "--transport", "zenoh", "--robots-per-process", "1")
    config = json.loads((shared / "config.json").read_text())
    assert config["robots_per_process"] == 3 and len(config["robot_hosts"]) == 3
    summaries = [json.loads((r / "summary.json").read_text()) for r in (shared, alone)]
    assert summaries[0]["events_sha256"] == summaries[1]["events_sha256"]
    assert summaries[0]["tasks"]["introduced"] >= 2
