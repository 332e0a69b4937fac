"""A lockstep run is a pure function of its world, seed and options.

Each run below is made twice: once as it comes (the session's shared run, which other
tests read too; in the boxpush one every robot profiles its loop), once with the runner and
every robot process restricted to one CPU that a busy process shares with them, without
its recording (`--no-record`: what run.mcap samples must not change the run) and without
profiles. Both must write exactly the events.jsonl recorded here (its sha256). A change
that alters what the robots or the allocation do legitimately changes these digests: rerun
with `MURDOCH_PRINT_DIGESTS=1` to see the new ones, check the runs' summaries, and update
the table.

numba compiles the sensing kernels for the CPU it runs on, so the digests hold on machines
with the same CPU features (see docs/experiments.md).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.timeout(600)

GOLDEN = {
    "boxpush": "ff5377a5e0e93f769488de0742849a79958483579f7f82533b464ac5768f1d21",
    "longterm": "e83264129e72b1174b54c9b09f3301d2eb9c861332aaf8878506c02439d81be9",
}
"""sha256 of events.jsonl for each run."""
OUTCOMES = {
    "boxpush": {"introduced": 12, "allocated": 12, "executed": 10, "failed": 2,
                "open_at_end": 0, "unachievable": 0, "reallocations": 1},
    "longterm": {"introduced": 5, "allocated": 4, "executed": 1, "failed": 0,
                 "open_at_end": 4, "unachievable": 0, "reallocations": 1},
}
"""What the same runs count in summary.json (the digest says the rest)."""


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


@contextmanager
def _one_busy_cpu() -> Iterator[int | None]:
    """One CPU of this process's set, with a busy loop running on it."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    cpu = min(os.sched_getaffinity(0))
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"],
                            preexec_fn=lambda: os.sched_setaffinity(0, {cpu}))
    try:
        yield cpu
    finally:
        busy.kill()
        busy.wait(10)


def _outcome(run: Path, recorded: bool, name: str) -> dict[str, object]:
    assert (run / "run.mcap").is_file() == recorded
    digest = hashlib.sha256((run / "events.jsonl").read_bytes()).hexdigest()
    summary = json.loads((run / "summary.json").read_text())
    assert summary["events_sha256"] == digest
    if os.environ.get("MURDOCH_PRINT_DIGESTS"):
        print(f"\n{name}: {digest} {summary['tasks']}", file=sys.stderr)
    return {"digest": digest, "summary": summary}


def _run_on(cpu: int | None, args: tuple[str, ...], out: Path) -> Path:
    extra = ["--no-pin-cpus", "--no-record"]
    if "--no-replay" not in args:
        extra.append("--no-replay")  # nothing to replay without a recording
    if "--no-plots" not in args:
        extra.append("--no-plots")  # (the events are what is compared)
    preexec = (lambda: os.sched_setaffinity(0, {cpu})) if cpu is not None else None
    proc = subprocess.run([*_murdoch(), *args, *extra, "--out", str(out)], capture_output=True,
                          text=True, timeout=560, check=False, preexec_fn=preexec)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    return run


@pytest.mark.parametrize("name", ["boxpush", "longterm"])
def test_a_seeded_lockstep_run_repeats_byte_for_byte_idle_and_on_one_loaded_cpu(
    name: str, tmp_path: Path, boxpush_switched_run: Any, longterm_killed_winner_run: Any
) -> None:
    shared = boxpush_switched_run if name == "boxpush" else longterm_killed_winner_run
    idle = _outcome(shared.run, True, name)
    with _one_busy_cpu() as cpu:
        loaded = _outcome(_run_on(cpu, shared.args, tmp_path / "loaded"), False, name)
    assert loaded["digest"] == idle["digest"]
    tasks = idle["summary"]["tasks"]  # type: ignore[index]
    assert {k: tasks[k] for k in OUTCOMES[name]} == OUTCOMES[name]
    assert idle["digest"] == GOLDEN[name]
