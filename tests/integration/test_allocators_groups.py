"""CBGA takes group tasks whole on real robot processes: each group task reaches the team as
one task that two robots hold at once, seat by seat; when one of them is killed the task
goes back whole and two robots take it again; the judge decides from the simulation as for
every allocator, and a run made twice writes the same events.jsonl."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from experiments import events as ev
from experiments.events import read_events
from experiments.soak.invariants import EventInvariants, Limits

pytestmark = pytest.mark.timeout(900)

ARGS = ["run", "longterm", "--allocator", "cbga", "--until", "5m", "--task-interval", "40",
        "--group-tasks", "0.6", "--seed", "4", "--kill", "p4@60s", "--restart",
        "p4@160s", "--no-replay", "--no-plots", "--no-record"]
"""With this seed p4 holds a seat of the first group task from the sixth second on."""


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _run(out: Path, results: dict[Path, Any]) -> None:
    proc = subprocess.run([*_murdoch(), *ARGS, "--out", str(out), "--no-pin-cpus"],
                          capture_output=True, text=True, timeout=800, check=False)
    if proc.returncode != 0:
        results[out] = proc.stdout[-3000:] + proc.stderr[-3000:]
        return
    (run,) = out.iterdir()
    results[out] = {"summary": json.loads((run / "summary.json").read_text()),
                    "events": read_events(run / "events.jsonl")}


@pytest.fixture(scope="module")
def twins(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    outs = [tmp_path_factory.mktemp("first"), tmp_path_factory.mktemp("second")]
    results: dict[Path, Any] = {}
    threads = [threading.Thread(target=_run, args=(o, results)) for o in outs]
    for t in threads:
        t.start()
    for t in threads:
        t.join(850)
    for o in outs:
        assert isinstance(results.get(o), dict), results.get(o)
    return [results[o] for o in outs]


def test_each_group_task_is_one_task_held_by_two_robots(twins: list[dict[str, Any]]) -> None:
    s, events = twins[0]["summary"], twins[0]["events"]
    handed = {e["task"]: e for e in events
              if e["kind"] == ev.TASK_INTRODUCED and e.get("source") == "group"}
    groups = [e for e in events if e["kind"] == ev.TASK_INTRODUCED and e.get("group")]
    assert groups and len(handed) == len(groups)  # one task per group, not two members
    assert all(e["params"]["required"] == 2 and e["task_kind"] == "watch-object-pair"
               for e in handed.values())
    assert s["group_tasks"]["completed"] >= 1
    awards = [e for e in events if e["kind"] == ev.AWARD and e["task"] in handed]
    by_time: dict[tuple[str, float], list[dict[str, Any]]] = {}
    for e in awards:
        by_time.setdefault((e["task"], e["t"]), []).append(e)
    for grant in by_time.values():  # every grant hands out both seats, to two robots
        assert sorted(e["seat"] for e in grant) == [0, 1]
        assert len({e["robot"] for e in grant}) == 2
    for done in (e for e in events if e["kind"] == ev.TASK_OUTCOME
                 and str(e["task"]).startswith("group-") and e["outcome"] == "completed"):
        assert len(set(done["robots"])) == 2
    checks = EventInvariants(Limits.defaults())
    for e in events:
        checks.apply(e)
    verdicts = checks.finish(float(s["sim_time_s"]))
    for name in ("terminal_states", "exclusive_execution", "reallocation_bound"):
        assert verdicts[name].held, (name, verdicts[name].first_counter_example)
    assert s["robot_failures"] == 1 and s["robot_restarts"] == 1


def test_a_killed_members_group_task_goes_back_whole(twins: list[dict[str, Any]]) -> None:
    events = twins[0]["events"]
    (lost,) = [e for e in events if e["kind"] == ev.REALLOCATION and e["from_robot"] == "p4"]
    assert lost["t"] > 60.0 and lost["task"].startswith("user.")
    again = [e for e in events if e["kind"] == ev.AWARD and e["task"] == lost["task"]
             and e["t"] > lost["t"]]
    assert sorted(e["seat"] for e in again) == [0, 1]
    assert "p4" not in {e["robot"] for e in again if e["t"] < 160.0}
    starts = [e for e in events if e["kind"] == "robot_task" and e.get("phase") == "start"
              and e.get("task") == lost["task"] and e["t"] > lost["t"]]
    assert len({e["robot"] for e in starts}) == 2


def test_a_run_with_groups_taken_whole_repeats_byte_for_byte(
        twins: list[dict[str, Any]]) -> None:
    assert twins[0]["summary"]["events_sha256"] == twins[1]["summary"]["events_sha256"]
