"""`murdoch sweep-longterm`: the long-term experiment over a range of task arrival rates.

The MURDOCH paper reports 49 tasks executed and 12 charging trips in about 3 hours, but gives
neither the rate at which tasks arrived nor their lengths, so those counts are a consequence
of the inputs. This command runs `murdoch run longterm` for every (`--task-interval`, seed)
pair, as separate processes (`--jobs` at a time), collects each run's summary.json into one
CSV row, prints a table and plots tasks executed, first-attempt unallocatable tasks, waits
(introduction to award) and charging trips against the offered load (tasks per hour), and
says which rate gives a target count of executed tasks (the paper's 49 in 3 hours).

The pure part (`row_of`, `by_interval`, `rate_for`) builds rows and reads them; `run_one` and
the click command are the process and file edges.
"""

from __future__ import annotations

import itertools
import json
import statistics
import sys
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from experiments.child_runs import parse_seeds, run_experiment, run_label, write_rows
from experiments.run_cli import parse_duration_s

PAPER_TASKS = 49
PAPER_SPAN_S = 3 * 3600.0
COLUMNS = (
    "task_interval_s", "offered_per_h", "seed", "sim_time_s", "introduced", "executed",
    "executed_per_3h", "failed", "first_attempt_unallocatable", "then_allocated",
    "unachievable_after_backoff", "wait_mean_s", "wait_median_s", "wait_p95_s",
    "never_awarded", "charging_trips", "reallocations", "robot_failures", "wall_time_s",
    "exit_code",
    "events_sha256", "run_dir",
)


@dataclass(frozen=True, slots=True)
class Job:
    task_interval_s: float
    seed: int

    def label(self) -> str:
        return run_label(f"i{self.task_interval_s:g}", self.seed)


def row_of(job: Job, summary: Mapping[str, Any] | None, exit_code: int,
           run_dir: Path | None) -> dict[str, Any]:
    """One CSV row from a run's summary.json (None: the run left none)."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(task_interval_s=job.task_interval_s, seed=job.seed,
               offered_per_h=round(3600.0 / job.task_interval_s, 3), exit_code=exit_code,
               run_dir=str(run_dir) if run_dir is not None else None)
    if summary is None:
        return row
    tasks, waits = summary["tasks"], summary.get("waits_s", {})
    sim_s = float(summary["sim_time_s"])
    row.update(
        sim_time_s=sim_s, introduced=tasks["introduced"], executed=tasks["executed"],
        executed_per_3h=round(tasks["executed"] * PAPER_SPAN_S / sim_s, 2) if sim_s else None,
        failed=tasks["failed"],
        first_attempt_unallocatable=tasks.get("first_attempt_unallocatable"),
        then_allocated=tasks.get("then_allocated"),
        unachievable_after_backoff=tasks.get("unachievable_after_backoff"),
        wait_mean_s=waits.get("mean"), wait_median_s=waits.get("median"),
        wait_p95_s=waits.get("p95"), never_awarded=waits.get("never_awarded"),
        charging_trips=summary["charging_trips"], reallocations=tasks["reallocations"],
        robot_failures=summary["robot_failures"],
        wall_time_s=summary.get("wall_time_s"), events_sha256=summary.get("events_sha256"),
    )
    return row


def _mean(values: Iterable[Any]) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return round(statistics.fmean(vals), 3) if vals else None


def by_interval(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The mean of every numeric column over the seeds of each interval, lowest load first."""
    out = []
    for interval in sorted({float(r["task_interval_s"]) for r in rows}, reverse=True):
        group = [r for r in rows if float(r["task_interval_s"]) == interval
                 and r["executed"] is not None]
        mean = {c: _mean(r[c] for r in group) for c in COLUMNS
                if c not in ("task_interval_s", "seed", "events_sha256", "run_dir")}
        out.append({"task_interval_s": interval, "runs": len(group), **mean})
    return out


def rate_for(means: Sequence[Mapping[str, Any]], target: float = PAPER_TASKS,
             column: str = "executed_per_3h") -> float | None:
    """The offered load (tasks per hour) at which the mean of `column` reaches `target`,
    interpolated linearly between the two sweep points around it; None when no pair of
    neighbouring points brackets it."""
    points = sorted((float(m["offered_per_h"]), float(m[column])) for m in means
                    if m.get(column) is not None and m.get("offered_per_h") is not None)
    exact = [x for x, y in points if y == target]
    if exact:
        return exact[0]
    for (x0, y0), (x1, y1) in itertools.pairwise(points):
        if min(y0, y1) < target < max(y0, y1):
            return round(x0 + (target - y0) * (x1 - x0) / (y1 - y0), 2)
    return None


def run_one(job: Job, *, out: Path, until_s: float, world: str | None, extra: Sequence[str],
            pin: bool) -> dict[str, Any]:
    """Run one long-term experiment as its own process; its row (from summary.json)."""
    code, run_dir, summary = run_experiment(
        "longterm", out / job.label(), until_s=until_s, seed=job.seed,
        options=["--task-interval", f"{job.task_interval_s:g}"],
        extra=[*extra, "--world", world] if world else extra, pin=pin, log_name="sweep.log")
    return row_of(job, summary, code, run_dir)


def write_csv(rows: Sequence[Mapping[str, Any]], path: Path) -> None:
    write_rows(rows, path, COLUMNS)


def format_table(means: Sequence[Mapping[str, Any]]) -> str:
    head = ("interval s", "tasks/h", "runs", "introduced", "executed", "exec/3h",
            "1st no bid", "unach.", "wait med s", "wait p95 s", "charging")
    keys = ("task_interval_s", "offered_per_h", "runs", "introduced", "executed",
            "executed_per_3h", "first_attempt_unallocatable", "unachievable_after_backoff",
            "wait_median_s", "wait_p95_s", "charging_trips")

    def cell(v: Any) -> str:
        if v is None:
            return "-"
        return f"{v:g}" if isinstance(v, float) else str(v)

    rows = [head, *[tuple(cell(m.get(k)) for k in keys) for m in means]]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True))
                     for r in rows)


def plot_sweep(rows: Sequence[Mapping[str, Any]], means: Sequence[Mapping[str, Any]],
               path: Path, target: float = PAPER_TASKS) -> Path:
    """Four panels against offered load: every run as a dot, the mean over seeds as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from experiments.plots import save

    panels = (
        ("executed_per_3h", "tasks executed (per 3 h)"),
        ("first_attempt_unallocatable", "first-attempt unallocatable"),
        ("wait_median_s", "wait, introduction to award (s)"),
        ("charging_trips", "charging trips"),
    )
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), dpi=100)
    ok = [r for r in rows if r["executed"] is not None]
    for ax, (key, title) in zip(axes.flat, panels, strict=True):
        ax.scatter([r["offered_per_h"] for r in ok], [r[key] for r in ok], s=14,
                   color="#868e96", label="runs")
        line = [(m["offered_per_h"], m[key]) for m in means if m.get(key) is not None]
        line.sort()
        ax.plot([x for x, _ in line], [y for _, y in line], marker="o", color="#f08c00",
                label="mean over seeds")
        if key == "wait_median_s":
            p95 = sorted((m["offered_per_h"], m["wait_p95_s"]) for m in means
                         if m.get("wait_p95_s") is not None)
            ax.plot([x for x, _ in p95], [y for _, y in p95], marker="^", linestyle="--",
                    color="#c2255c", label="mean p95")
        if key == "executed_per_3h":
            ax.axhline(target, color="#1c7ed6", linewidth=0.9, label=f"paper: {target:g}")
        ax.set_title(title)
        ax.set_xlabel("offered load (tasks per hour)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    fig.suptitle("Long-term experiment against offered load")
    fig.tight_layout()
    return save(fig, path)


def _floats(text: str, option: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"expected comma-separated numbers, got {text!r}",
                                 param_hint=option) from None
    if not values or any(not v > 0 for v in values):
        raise click.BadParameter(f"expected positive numbers, got {text!r}", param_hint=option)
    return values


@click.command("sweep-longterm")
@click.option("--intervals", default="90,120,180,240,360", show_default=True,
              help="Mean simulated seconds between new tasks, comma-separated.")
@click.option("--seeds", default="1,2", show_default=True, help="Seeds: 1,2,3 or 1-4.")
@click.option("--until", "until", default="3h", show_default=True,
              help="Simulated span of every run, e.g. 3h, 90m.")
@click.option("--jobs", type=click.IntRange(1, 64), default=2, show_default=True,
              help="Runs at a time (each its own runner and robot processes).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path("runs/sweep-longterm"), show_default=True)
@click.option("--world", default=None, help="World name or .toml (default: longterm).")
@click.option("--metric", "metric_terms", default="",
              help="Passed to every run: terms added to the robots' task metrics.")
@click.option("--target", type=float, default=PAPER_TASKS, show_default=True,
              help="Executed tasks per 3 h to find the rate for (the paper's 49).")
def sweep_longterm(intervals: str, seeds: str, until: str, jobs: int, out: Path,
                   world: str | None, metric_terms: str, target: float) -> None:
    """Run the long-term experiment over task intervals and seeds; CSV, table and plots."""
    values = _floats(intervals, "--intervals")
    seed_list = parse_seeds(seeds)
    until_s = parse_duration_s(until)
    if metric_terms:
        from experiments.run_cli import _metric_terms

        _metric_terms(metric_terms)  # a bad term is refused before anything runs
    extra = ["--metric", metric_terms] if metric_terms else []
    out.mkdir(parents=True, exist_ok=True)
    todo = [Job(i, s) for i in values for s in seed_list]
    click.echo(f"{len(todo)} runs of {until_s:g} s simulated, {jobs} at a time, into {out}")
    # one run at a time may pin its serving thread; several would share that CPU
    pin = jobs == 1

    def one(job: Job) -> dict[str, Any]:
        row = run_one(job, out=out, until_s=until_s, world=world, extra=extra, pin=pin)
        click.echo(f"  {job.label()}: exit {row['exit_code']}, executed {row['executed']}, "
                   f"first-attempt unallocatable {row['first_attempt_unallocatable']}, "
                   f"charging trips {row['charging_trips']} ({row['wall_time_s']} s wall)")
        return row

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        rows = list(pool.map(one, todo))
    rows.sort(key=lambda r: (-float(r["task_interval_s"]), int(r["seed"])))
    write_csv(rows, out / "sweep.csv")
    means = by_interval(rows)
    (out / "sweep-means.json").write_text(json.dumps(means, indent=2) + "\n", encoding="utf-8")
    plot = plot_sweep(rows, means, out / "sweep.png", target)
    click.echo(format_table(means))
    rate = rate_for(means, target)
    if rate is None:
        click.echo(f"no two neighbouring loads bracket {target:g} executed tasks per 3 h")
    else:
        click.echo(f"{target:g} executed tasks per 3 h at about {rate:g} tasks offered per hour "
                   f"(a mean task interval of about {3600.0 / rate:.0f} s)")
    click.echo(f"wrote {out / 'sweep.csv'}, {plot}")
    broken = [r for r in rows if r["robot_failures"]]
    if broken:
        # no failures are scheduled here: a robot that exited (e.g. timed out waiting for an
        # overloaded machine) makes its run a different experiment
        click.echo("warning: robot processes exited by themselves in "
                   + ", ".join(f"{Job(r['task_interval_s'], r['seed']).label()} "
                               f"({r['robot_failures']})" for r in broken), err=True)
    failed = [r for r in rows if r["exit_code"] != 0]
    if failed:
        click.echo(f"error: {len(failed)} run(s) did not end cleanly: "
                   + ", ".join(f"{Job(r['task_interval_s'], r['seed']).label()} "
                               f"(exit {r['exit_code']})" for r in failed), err=True)
        sys.exit(1)
