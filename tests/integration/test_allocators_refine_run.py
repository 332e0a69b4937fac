"""CBBA and CBGA with `--refine` on real robot processes: a real server, real robot
processes, real multicast on loopback, in lockstep.

A short run of `worlds/test_lowbattery.toml` (two robots and the overhead camera's desk,
a task every 15 s on average) per algorithm, plus the CBBA run again, all three at once:
each must complete tasks with every robot told `--refine`, run improvement phases, never
let two robots execute one task at once (there are no group tasks here), and the two CBBA
runs must write the same events.jsonl (lockstep determinism, whatever the load).
"""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from experiments.events import read_events
from experiments.soak.invariants import EventInvariants, Limits

pytestmark = pytest.mark.timeout(900)

ARGS = ["run", "longterm", "--world", "test_lowbattery", "--until", "90s",
        "--task-interval", "15", "--seed", "3", "--refine", "--no-replay", "--no-plots",
        "--no-record", "--no-pin-cpus"]


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(allocator: str, out: Path) -> dict[str, Any]:
    proc = subprocess.run([*_murdoch(), *ARGS, "--allocator", allocator, "--out", str(out)],
                          capture_output=True, text=True, timeout=800, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    (run,) = out.iterdir()
    auction = [json.loads(line) for f in sorted((run / "logs").glob("*.auction.jsonl"))
               for line in f.read_text().splitlines() if line.strip()]
    return {"summary": json.loads((run / "summary.json").read_text()),
            "events": read_events(run / "events.jsonl"),
            "config": json.loads((run / "config.json").read_text()),
            "auction": auction}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    names = ["cbba", "cbga", "cbba-again"]
    # the directories first, on this thread: pytest's temporary-path factory is not made to be
    # called from several threads at once
    dirs = {n: tmp_path_factory.mktemp(n) for n in names}
    with ThreadPoolExecutor(max_workers=len(names)) as pool:
        done = pool.map(lambda n: _run(n.removesuffix("-again"), dirs[n]), names)
        return dict(zip(names, done, strict=True))


@pytest.mark.parametrize("allocator", ["cbba", "cbga"])
def test_refined_robots_complete_tasks_without_two_on_one(runs: dict[str, dict[str, Any]],
                                                         allocator: str) -> None:
    run = runs[allocator]
    s, config = run["summary"], run["config"]
    assert s["allocator"] == allocator and s["refine"] is True and config["refine"] is True
    assert all("--refine" in p["args"] for p in config["processes"])
    assert s["tasks"]["executed"] >= 1
    assert s["messages"]["by_kind"]["team-refine"]["count"] > 0
    assert any(e["kind"] == "refined" for e in run["auction"])  # phases agreed on plans
    checks = EventInvariants(Limits.defaults())
    for e in run["events"]:
        checks.apply(e)
    verdicts = checks.finish(float(s["sim_time_s"]))
    for name in ("terminal_states", "exclusive_execution"):
        assert verdicts[name].held, (name, verdicts[name].first_counter_example)


def test_a_refined_lockstep_run_repeats_byte_for_byte(runs: dict[str, dict[str, Any]]) -> None:
    assert runs["cbba"]["summary"]["events_sha256"] == \
        runs["cbba-again"]["summary"]["events_sha256"]
