"""`murdoch run --robots-per-process 3`: the longterm team (six robots and the camera desk)
in three host processes, its busy robot killed and restarted inside its host; the run is the
one-process-per-robot run's twin (the same events.jsonl)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from experiments import events as ev

pytestmark = pytest.mark.timeout(600)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


@pytest.fixture(scope="module")
def hosted_run(tmp_path_factory: pytest.TempPathFactory,
               longterm_killed_winner_run: Any) -> tuple[str, Path]:
    """The shared killed-winner run (conftest.py) again, robots three to a process."""
    out = tmp_path_factory.mktemp("robots-per-process") / "runs"
    proc = subprocess.run(
        [*_murdoch(), *longterm_killed_winner_run.args, "--robots-per-process", "3",
         "--no-replay", "--no-plots", "--out", str(out)],
        capture_output=True, text=True, timeout=560, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    return proc.stdout, run


def _read(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_robots_three_to_a_process_make_the_same_run_as_one_to_a_process(
    hosted_run: tuple[str, Path], longterm_killed_winner_run: Any
) -> None:
    _, run = hosted_run
    config = json.loads((run / "config.json").read_text())
    assert config["robots_per_process"] == 3
    assert [h["robots"] for h in config["robot_hosts"]] == [
        ["p1", "p2", "p3"], ["p4", "p5", "p6"], ["desktop"]]
    summary = json.loads((run / "summary.json").read_text())
    twin = json.loads((longterm_killed_winner_run.run / "summary.json").read_text())
    assert summary["events_sha256"] == twin["events_sha256"]
    assert summary["tasks"] == twin["tasks"] and summary["tasks"]["allocated"] >= 2
    assert summary["tasks"]["executed"] >= 1 and summary["tasks"]["reallocations"] >= 1


def test_the_killed_robot_is_down_and_back_inside_its_host(hosted_run: tuple[str, Path]) -> None:
    _, run = hosted_run
    events = _read(run / "events.jsonl")
    (failure,) = [e for e in events if e["kind"] == ev.ROBOT_FAILURE]
    victim = failure["robot"]
    assert (failure["t"], failure["reason"]) == (45.0, "killed")
    assert [(e["t"], e["robot"]) for e in events if e["kind"] == ev.ROBOT_RESTART] == [
        (90.0, victim)]
    realloc = [e for e in events if e["kind"] == ev.REALLOCATION]
    assert realloc and realloc[0]["from_robot"] == victim
    # the kill and the restart were the victim's alone: its host process went on
    notes = [e for e in _read(run / "processes.jsonl") if e["kind"] == "process_note"]
    host_pid = next(e["pid"] for e in notes if e["robot"] == victim)
    assert [(e["what"], e["pid"]) for e in notes if e["robot"] == victim] == [
        ("started", host_pid), ("killed", host_pid), ("started", host_pid)]
    assert not [e for e in notes if e["what"] == "exited"]
    config = json.loads((run / "config.json").read_text())
    (host,) = [h["name"] for h in config["robot_hosts"] if victim in h["robots"]]
    log = (run / "logs" / f"{host}.log").read_text(errors="replace")
    assert "Traceback" not in log
    ready = [json.loads(line)["ready"]["robot"] for line in log.splitlines()
             if line.startswith('{"ready"')]
    (robots,) = [h["robots"] for h in config["robot_hosts"] if h["name"] == host]
    assert sorted(ready) == sorted([*robots, victim])  # the victim came up twice
    # memory is sampled per host, with the robots it runs
    processes = json.loads((run / "summary.json").read_text())["processes"]
    assert {n: p["robots"] for n, p in processes.items() if n != "runner"} == {
        "host-0": 3, "host-1": 3, "host-2": 1}
    assert all(p["peak_rss_per_robot_bytes"] > 0 for n, p in processes.items()
               if n != "runner")
