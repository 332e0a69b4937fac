"""`murdoch compare --resume`: which finished runs under `--out` a comparison may reuse.

In lockstep a run is a pure function of its world, seed and options, so a finished run made
with the same ones is the run the comparison would make again. A run is reused when its
directory (the newest under `OUT/<allocator>-s<seed>/`) holds a summary.json of a run that
ended `completed` and a config.json whose options are exactly the comparison's
(`expected_config`); anything else (no summary, an error, other options, another world) is
run again. The check reads only the run directory; `reusable_run` is its file edge.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

COMPARED_KEYS: tuple[str, ...] = (
    "experiment", "allocator", "refine", "seed", "duration_s", "task_interval_s",
    "group_task_rate", "kills", "restarts", "world", "lockstep",
)
"""The config.json fields that must match for a run to be reused."""


def expected_config(*, allocator: str, refine: bool, seed: int, until_s: float,
                    task_interval_s: float, kills: Sequence[str],
                    restarts: Sequence[str], world: str | None, experiment: str = "longterm",
                    own: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """What a run of this comparison writes in config.json, in the compared fields (`own`:
    the experiment's own entries, `Experiment.config`; `world` None: its default)."""
    own = dict(own or {})
    return {"experiment": experiment, "allocator": allocator, "refine": refine, "seed": seed,
            "duration_s": float(until_s), "task_interval_s": float(task_interval_s),
            "kills": list(kills), "restarts": list(restarts), "world": world or experiment,
            "lockstep": True, **own,
            "group_task_rate": float(own.get("group_task_rate", 0.0))}


def mismatch(config: Mapping[str, Any], summary: Mapping[str, Any],
             expected: Mapping[str, Any]) -> str | None:
    """Why a finished run cannot stand for this comparison's (None: it can)."""
    if summary.get("end_reason", "completed") != "completed":
        return f"it ended {summary.get('end_reason')!r}"
    for key in (*COMPARED_KEYS, *(k for k in expected if k not in COMPARED_KEYS)):
        found, want = config.get(key), expected[key]
        if key == "group_task_rate" and found is None:
            found = 0.0  # (a run without group tasks writes none)
        if isinstance(want, float) and isinstance(found, int | float):
            if abs(float(found) - want) > 1e-9:
                return f"{key} is {found!r}, this comparison's is {want!r}"
        elif found != want:
            return f"{key} is {found!r}, this comparison's is {want!r}"
    return None


def reusable_run(label_dir: Path, expected: Mapping[str, Any]) -> tuple[Path | None, str]:
    """The newest run directory under `label_dir` that may be reused, or None and why not."""
    runs = sorted(p for p in label_dir.iterdir() if p.is_dir()) if label_dir.is_dir() else []
    if not runs:
        return None, "no run yet"
    run = runs[-1]
    try:
        config = json.loads((run / "config.json").read_text(encoding="utf-8"))
        summary = json.loads((run / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return None, f"{run.name} did not finish ({type(exc).__name__})"
    why = mismatch(config, summary, expected)
    return (run, "") if why is None else (None, f"{run.name}: {why}")
