"""What the multi-run commands (`murdoch compare`, `murdoch sweep-longterm`) share.

Each runs `murdoch run ...` once per point of its grid and seed, as its own process with its
output logged next to its run directory (named by `run_label`), reads back the run's
summary.json and writes one CSV row per run; the seeds they take are given the same way
(`--seeds 1,2,3` or `1-4`).
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import click


def murdoch_command() -> list[str]:
    """The `murdoch` command next to this interpreter (or the package run by it)."""
    exe = Path(sys.executable).parent / "murdoch"
    if exe.exists():
        return [str(exe)]
    return [sys.executable, "-c", "import sys; from experiments.cli import main; sys.exit(main())"]


def parse_seeds(text: str) -> list[int]:
    """'1,2,3' or '1-4' -> the seeds; a clear error naming --seeds otherwise."""
    try:
        if "-" in text and "," not in text:
            lo, hi = (int(v) for v in text.split("-", 1))
            values = list(range(lo, hi + 1))
        else:
            values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"expected seeds such as 1,2,3 or 1-4, got {text!r}",
                                 param_hint="--seeds") from None
    if not values:
        raise click.BadParameter(f"no seed in {text!r}", param_hint="--seeds")
    return values


def run_child(args: Sequence[str], run_out: Path, log_name: str
              ) -> tuple[int, Path | None, dict[str, Any] | None]:
    """Run `murdoch` with `args` (which name `run_out` as its --out), its output logged to
    run_out/log_name; (exit code, the newest run directory in run_out, its summary.json: None
    when it left none)."""
    with (run_out / log_name).open("w", encoding="utf-8") as log_file:
        code = subprocess.run([*murdoch_command(), *args], stdout=log_file,
                              stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                              check=False).returncode
    runs = sorted(p for p in run_out.iterdir() if p.is_dir())
    run_dir = runs[-1] if runs else None
    summary = None
    if run_dir is not None and (run_dir / "summary.json").is_file():
        summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    return code, run_dir, summary


def run_label(point: str, seed: int) -> str:
    """The name of the run directory of grid point `point` with `seed` (`cbba-s2`)."""
    return f"{point}-s{seed}"


def run_experiment(experiment: str, run_out: Path, *, until_s: float, seed: int,
                   options: Sequence[str], extra: Sequence[str], pin: bool, log_name: str
                   ) -> tuple[int, Path | None, dict[str, Any] | None]:
    """`murdoch run EXPERIMENT` once into `run_out` (made if missing) for `until_s` simulated
    seconds with `seed`, its `options` and the caller's `extra` ones, without a replay and,
    unless `pin`, without pinning CPUs; what `run_child` returns."""
    run_out.mkdir(parents=True, exist_ok=True)
    args = ["run", experiment, "--until", f"{until_s:g}s", *options, "--seed", str(seed),
            "--out", str(run_out), "--no-replay", *extra]
    if not pin:
        args.append("--no-pin-cpus")
    return run_child(args, run_out, log_name)


def write_rows(rows: Sequence[Mapping[str, Any]], path: Path, columns: Sequence[str]) -> None:
    """The rows as CSV, one column per name in `columns` (missing values left empty)."""
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns))
        writer.writeheader()
        for row in rows:
            writer.writerow({c: row.get(c) for c in columns})
