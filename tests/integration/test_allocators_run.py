"""MURDOCH, CBBA and CBGA on real robot processes: the same short run through a kill, a
restart and charging trips, with the same task stream, batteries and faults for each.

`worlds/test_lowbattery.toml` has two robots with tiny batteries (both charge within the
first minute and a half) and an overhead camera; tasks come every 20 s on average. The run
kills r2 while it executes a task, restarts it 40 s later, and lasts four simulated
minutes. Each allocator must complete tasks, reallocate the killed robot's task, never let
two robots execute one task at once, and end every task in exactly one terminal state; a
CBBA run made twice must write the same events.jsonl. The same runs show that charging trips
are counted as completed cycles.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from experiments import events as ev
from experiments.events import read_events
from experiments.soak.invariants import EventInvariants, Limits
from murdoch.allocators import ALLOCATORS as REGISTRY

pytestmark = pytest.mark.timeout(900)

ARGS = ["run", "longterm", "--world", "test_lowbattery", "--until", "240s",
        "--task-interval", "20", "--seed", "3", "--kill", "r2@30s", "--restart", "r2@70s",
        "--no-replay", "--no-plots", "--no-record"]
ALLOCATORS = list(REGISTRY)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(allocator: str, out: Path) -> dict[str, Any]:
    proc = subprocess.run([*_murdoch(), *ARGS, "--allocator", allocator, "--out", str(out)],
                          capture_output=True, text=True, timeout=800, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    (run,) = out.iterdir()
    return {"summary": json.loads((run / "summary.json").read_text()),
            "events": read_events(run / "events.jsonl"),
            "config": json.loads((run / "config.json").read_text())}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    return {a: _run(a, tmp_path_factory.mktemp(a)) for a in ALLOCATORS}


def _stream(events: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
    """What the seed fixes whatever the allocator: the user's tasks and the faults."""
    return [(e["t"], e["kind"], e.get("task_kind"), json.dumps(e.get("params"), sort_keys=True),
             e.get("robot")) for e in events
            if (e["kind"] == "task_introduced" and e.get("source") == "user")
            or e["kind"] in ("robot_failure", "robot_restart")]


@pytest.mark.parametrize("allocator", ALLOCATORS)
def test_each_allocator_completes_tasks_through_a_kill_a_restart_and_charging(
        runs: dict[str, dict[str, Any]], allocator: str) -> None:
    run = runs[allocator]
    s = run["summary"]
    assert s["allocator"] == allocator
    assert run["config"]["allocator"] == allocator
    # a MURDOCH robot's command line stays as it always was; the others name their allocator
    named = [f"--allocator {allocator}" in " ".join(p["args"])
             for p in run["config"]["processes"]]
    assert all(named) if allocator != "murdoch" else not any(named)
    assert s["tasks"]["executed"] >= 2
    assert s["tasks"]["reallocations"] >= 1  # the killed robot's task
    assert s["robot_failures"] >= 1 and s["robot_restarts"] == 1
    assert s["charging_trips"] >= 1
    assert s["invariant_terminal_states"]["holds"]
    checks = EventInvariants(Limits.defaults())
    for e in run["events"]:
        checks.apply(e)
    verdicts = checks.finish(float(s["sim_time_s"]))
    for name in ("terminal_states", "exclusive_execution", "reallocation_bound"):
        assert verdicts[name].held, (name, verdicts[name].first_counter_example)


@pytest.mark.parametrize("allocator", ALLOCATORS)
def test_charging_trips_are_completed_cycles(runs: dict[str, dict[str, Any]],
                                             allocator: str) -> None:
    """A robot is sent to charge and comes back; summary.json counts the charge starts, and
    as charging trips each robot's charge ends that close an open start."""
    s, events = runs[allocator]["summary"], runs[allocator]["events"]
    starts = [e for e in events if e["kind"] == ev.CHARGE_START]
    ends = [e for e in events if e["kind"] == ev.CHARGE_END]
    assert ends and ends[0]["robot"] == starts[0]["robot"] and ends[0]["t"] > starts[0]["t"]
    open_: set[str] = set()
    cycles = 0
    for e in events:
        if e["kind"] == ev.CHARGE_START:
            open_.add(e["robot"])
        elif e["kind"] == ev.CHARGE_END and e["robot"] in open_:
            open_.discard(e["robot"])
            cycles += 1
    assert s["charging_trips"] == cycles >= 1
    assert s["charging_starts"] == len(starts)


def test_the_same_seed_gives_every_allocator_the_same_tasks_and_faults(
        runs: dict[str, dict[str, Any]]) -> None:
    streams = {a: _stream(runs[a]["events"]) for a in ALLOCATORS}
    assert len(streams["murdoch"]) > 5
    assert all(streams[a] == streams["murdoch"] for a in ALLOCATORS)


@pytest.mark.parametrize("allocator", ["cbba", "optimal"])
def test_a_run_repeats_byte_for_byte(runs: dict[str, dict[str, Any]], tmp_path: Path,
                                     allocator: str) -> None:
    again = _run(allocator, tmp_path / "again")
    assert again["summary"]["events_sha256"] == runs[allocator]["summary"]["events_sha256"]
