"""Sweeps of the paper's experiments: parallel runs, aggregation and the results table."""

from __future__ import annotations

import csv
import functools
import json
import logging
import math
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

from murdoch.consensus.cbba_fast import load_compiled_cbba
from murdoch.consensus.cbga_fast import load_compiled_cbga
from murdoch.consensus.experiments import EXPERIMENTS, RunRecord, run_one

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Job:
    experiment: str
    variant_index: int
    n_agents: int
    run: int
    seed: int
    refine: bool = False
    cost: str = "discount"
    team_mode: str = "bonus"


@dataclass(frozen=True)
class Summary:
    experiment: str
    variant: str
    n_agents: int
    runs: int
    score_mean: float
    score_std: float
    steps_mean: float
    steps_std: float
    messages_mean: float
    messages_std: float
    bytes_mean: float
    bytes_std: float
    solve_ms_mean: float
    converged: int
    conflict_free: int
    pairwise_mean: float = math.nan
    pairwise_std: float = math.nan
    bytes_dense_mean: float = math.nan
    bytes_dense_std: float = math.nan


def parse_agents(text: str) -> tuple[int, ...]:
    """'1-10', '5', '2,4,8' or a mix such as '1-3,8'."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        if "-" in part:
            lo, hi = part.split("-", 1)
            a, b = int(lo), int(hi)
            if a > b:
                raise ValueError(f"agent range {part!r} runs backwards")
            out.extend(range(a, b + 1))
        else:
            out.append(int(part))
    if not out or min(out) < 1:
        raise ValueError(f"agent counts must be positive integers, got {text!r}")
    return tuple(sorted(set(out)))


def jobs_for(experiment: str, agents: Sequence[int], runs: int, seed: int,
             refine: bool = False, cost: str = "discount", team_mode: str = "bonus"
             ) -> list[Job]:
    variants = EXPERIMENTS[experiment]
    return [Job(experiment, v, n, r, seed, refine, cost, team_mode)
            for n in agents for v in range(len(variants)) for r in range(runs)]


def load_kernels(cbba: bool, cbga: bool) -> None:
    """Load the compiled CBBA and/or CBGA runs in this process (a pool initialiser)."""
    if cbba:
        load_compiled_cbba()
    if cbga:
        load_compiled_cbga()


def _run_chunk(chunk: list[Job]) -> list[RunRecord]:
    return [run_one(j.experiment, j.variant_index, j.n_agents, j.run, j.seed, refine=j.refine,
                    cost=j.cost, team_mode=j.team_mode)
            for j in chunk]


def run_jobs(jobs: Sequence[Job], n_procs: int,
             progress: Callable[[int, int], None] | None = None,
             dask_address: str | None = None) -> list[RunRecord]:
    """Run jobs in `n_procs` worker processes (1 = in this process), or on the workers of
    the Dask scheduler at `dask_address` (`murdoch.dask_jobs`: the same chunks, and every
    worker loads the compiled runs first); the records come in job order either way, and
    each job carries its seed, so they are the same records but for the solve times."""
    size = max(1, min(25, len(jobs) // max(1, n_procs * 8)))
    chunks = [list(jobs[i:i + size]) for i in range(0, len(jobs), size)]
    out: list[RunRecord] = []
    # the compiled runs the jobs use are loaded (or compiled and cached on disk) once here,
    # before any worker starts: workers then only load them, outside the solve times they
    # record
    algorithms = {EXPERIMENTS[j.experiment][j.variant_index].algorithm for j in jobs}
    cbba, cbga = "cbba" in algorithms, "cbga" in algorithms
    if cbba or cbga:
        load_kernels(cbba, cbga)
    if dask_address is not None:
        from murdoch.dask_jobs import run_in_order

        def chunk_done(records: list[RunRecord]) -> None:
            out.extend(records)
            if progress:
                progress(len(out), len(jobs))

        run_in_order(dask_address, _run_chunk, chunks,
                     functools.partial(load_kernels, cbba, cbga), chunk_done)
        return out
    if n_procs <= 1:
        for chunk in chunks:
            out.extend(_run_chunk(chunk))
            if progress:
                progress(len(out), len(jobs))
        return out
    with ProcessPoolExecutor(max_workers=n_procs,
                             initializer=load_kernels, initargs=(cbba, cbga)) as pool:
        for records in pool.map(_run_chunk, chunks):
            out.extend(records)
            if progress:
                progress(len(out), len(jobs))
    return out


def _mean_std(xs: Sequence[float]) -> tuple[float, float]:
    n = len(xs)
    if n == 0:
        return math.nan, math.nan
    mean = sum(xs) / n
    if n == 1:
        return mean, 0.0
    var = sum((x - mean) ** 2 for x in xs) / (n - 1)
    return mean, math.sqrt(var)


def summarise(records: Iterable[RunRecord]) -> list[Summary]:
    groups: dict[tuple[str, str, int], list[RunRecord]] = {}
    order: dict[str, int] = {}
    for r in records:
        groups.setdefault((r.experiment, r.variant, r.n_agents), []).append(r)
    for exp, variants in EXPERIMENTS.items():
        for n, v in enumerate(variants):
            order[f"{exp}/{v.name}"] = n
    out = []
    for (exp, variant, n), rs in sorted(
            groups.items(), key=lambda kv: (kv[0][0], order.get(f"{kv[0][0]}/{kv[0][1]}", 0),
                                            kv[0][2])):
        sm, ss = _mean_std([r.score for r in rs])
        # communication is summarised over the runs that converged (a run that hit the
        # round limit would only measure the limit); the count is reported beside it
        done = [r for r in rs if r.converged] or rs
        tm, ts = _mean_std([float(r.steps) for r in done])
        mm, ms = _mean_std([float(r.messages) for r in done])
        bm, bs = _mean_std([float(r.bytes) for r in done])
        pm, ps = _mean_std([float(r.pairwise_steps) for r in done])
        dm, ds = _mean_std([float(r.bytes_dense) for r in done])
        out.append(Summary(exp, variant, n, len(rs), sm, ss, tm, ts, mm, ms, bm, bs,
                           1000 * sum(r.solve_s for r in rs) / len(rs),
                           sum(r.converged for r in rs), sum(r.conflict_free for r in rs),
                           pm, ps, dm, ds))
    return out


def markdown_table(rows: Sequence[Summary]) -> str:
    lines = ["| experiment | variant | agents | runs | score | steps* | pairwise steps* "
             "| messages* | bytes* | dense bytes* | solve ms | converged | conflict-free |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r.experiment} | {r.variant} | {r.n_agents} | {r.runs} "
            f"| {r.score_mean:.0f} ± {r.score_std:.0f} | {r.steps_mean:.1f} ± {r.steps_std:.1f} "
            f"| {r.pairwise_mean:.0f} ± {r.pairwise_std:.0f} "
            f"| {r.messages_mean:.0f} ± {r.messages_std:.0f} "
            f"| {r.bytes_mean:.0f} ± {r.bytes_std:.0f} "
            f"| {r.bytes_dense_mean:.0f} ± {r.bytes_dense_std:.0f} | {r.solve_ms_mean:.0f} "
            f"| {r.converged}/{r.runs} | {r.conflict_free}/{r.runs} |")
    lines.append("")
    lines.append("Mean ± standard deviation over runs; * over the runs that converged. Steps "
                 "are rounds; pairwise steps are the sends that carried changed allocation "
                 "data; dense bytes are the same messages as dense matrices.")
    return "\n".join(lines) + "\n"


def write_outputs(out_dir: Path, records: Sequence[RunRecord], rows: Sequence[Summary],
                  meta: dict[str, object]) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    p = out_dir / "runs.csv"
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(asdict(records[0]).keys()) if records else [])
        w.writeheader()
        for r in records:
            w.writerow(asdict(r))
    written.append(p)
    p = out_dir / "summary.json"
    p.write_text(json.dumps({"meta": meta, "rows": [asdict(r) for r in rows]}, indent=1),
                 encoding="utf-8")
    written.append(p)
    p = out_dir / "results.md"
    p.write_text(markdown_table(rows), encoding="utf-8")
    written.append(p)
    return written
