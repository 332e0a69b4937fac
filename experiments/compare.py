"""`murdoch compare longterm`: the allocators side by side on the same task streams.

Every (allocator, seed) pair is one `murdoch run longterm --allocator A --seed S` process
(`--jobs` at a time, or on the workers of a Dask cluster with `--dask`; each with its own
Player ports, multicast port and team key, as every `murdoch run` has), under the same
options: the same seed gives every allocator the same task stream, batteries and fault
schedule (`--kill`, `--restart` apply to each run alike). From each run directory's
summary.json and events.jsonl it takes one row of `comparison.csv` (on the host that ran it),
then writes `comparison.png` and prints the mean ± standard deviation over seeds per allocator:
tasks completed, time from introduction to start, distance driven, messages and bytes per
task, group tasks completed, reallocations after kills and unachievable tasks. When `optimal`
ran too, every other allocator is also set against it seed by seed (`compare_paired`:
`comparison-paired.csv`, `comparison-paired.png` and a second table).

A consensus allocator's refined form is compared as an allocator of its own: `cbba+refine`
runs `--allocator cbba --refine` (`REFINED`); `--refine` adds the refined form of every
consensus allocator listed, next to the plain one.

The pure part (`run_row`, `error_row`, `rows_in_order`, `start_waits`,
`reallocations_after_kills`, `mean_std`, `by_allocator`, `format_table`) builds, gathers and
reads rows; `run_one` and the click command are the process and file edges, and where the runs
go (a thread pool here, or `murdoch.dask_jobs.connected`) is the `submit` given to
`rows_in_order`.
"""

from __future__ import annotations

import functools
import json
import math
import statistics
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import click

from experiments import events as ev
from experiments.child_runs import parse_seeds, run_experiment, run_label, write_rows
from experiments.option_params import add_passthrough_params, passthrough_args
from experiments.registry import experiments, supporting
from experiments.run_cli import parse_at, parse_duration_s
from murdoch.allocators import ALLOCATORS, REFINABLE

if TYPE_CHECKING:
    from murdoch.dask_jobs import Submit

METRICS: tuple[tuple[str, str], ...] = (
    ("tasks_completed", "tasks completed"),
    ("wait_mean_s", "introduction to start (s)"),
    ("distance_m", "distance driven (m)"),
    ("messages_per_task", "messages per task"),
    ("bytes_per_task", "bytes per task"),
    ("group_tasks_completed", "group tasks completed"),
    ("reallocations_after_kills", "reallocations after kills"),
    ("unachievable", "unachievable tasks"),
)
"""The compared figures: column of comparison.csv, and its label in the table and plot."""
COLUMNS: tuple[str, ...] = (
    "allocator", "seed", "exit_code", "sim_time_s", "tasks_introduced",
    *(key for key, _ in METRICS), "messages", "bytes", "wall_time_s", "events_sha256",
    "run_dir", "error",
)


REFINED = "+refine"
"""The suffix that names an allocator's refined form (`cbba+refine`)."""
ALLOCATOR_NAMES: tuple[str, ...] = tuple(ALLOCATORS)
"""The registered allocators, in the registry's order (MURDOCH first)."""
COMPARABLE: tuple[str, ...] = (*ALLOCATOR_NAMES, *(a + REFINED for a in REFINABLE))
JOBS = 2
"""Runs at a time on this machine unless `--jobs` says otherwise."""


@dataclass(frozen=True, slots=True)
class Job:
    allocator: str
    seed: int

    def label(self) -> str:
        return run_label(self.allocator, self.seed)

    def allocator_args(self) -> list[str]:
        """`murdoch run`'s options for this allocator (`--refine` for a refined form)."""
        if self.allocator.endswith(REFINED):
            return ["--allocator", self.allocator.removesuffix(REFINED), "--refine"]
        return ["--allocator", self.allocator]


# -- one run's figures (pure) ----------------------------------------------------------------


def _user_task(e: Mapping[str, Any]) -> bool:
    return e.get("source") in (None, "user")


def start_waits(events: Iterable[Mapping[str, Any]]) -> list[float]:
    """Simulated seconds from each user task's introduction to the start of its execution:
    the first `robot_task` start of the task; for a group task, the moment the last of its
    robots started (its members carry it as `parent`; a member taken whole by a group of
    robots, `required` of them in its params, starts when the last of them does). Tasks
    never started are left out."""
    introduced: dict[str, float] = {}
    groups: dict[str, set[str]] = {}
    needs: dict[str, int] = {}
    starts: dict[str, dict[str, float]] = {}
    for e in events:
        kind = e["kind"]
        if kind == ev.TASK_INTRODUCED:
            task = str(e["task"])
            if _user_task(e):
                introduced.setdefault(task, float(e["t"]))
                if e.get("group"):
                    groups.setdefault(task, set())
            elif e.get("parent") is not None:
                groups.setdefault(str(e["parent"]), set()).add(task)
                params = e.get("params")
                if isinstance(params, Mapping) and "members" in params:
                    needs[task] = len(params["members"])
        elif kind == "robot_task" and e.get("phase") == "start" and "task" in e:
            starts.setdefault(str(e["task"]), {}).setdefault(str(e.get("robot")),
                                                            float(e["t"]))
    started: dict[str, float] = {}
    for task, by_robot in starts.items():
        times = sorted(by_robot.values())
        if len(times) >= needs.get(task, 1):
            started[task] = times[needs.get(task, 1) - 1]
    waits = []
    for task, t0 in introduced.items():
        members = groups.get(task)
        if members is None:
            if task in started:
                waits.append(started[task] - t0)
        elif members and all(m in started for m in members):
            waits.append(max(started[m] for m in members) - t0)
    return waits


def reallocations_after_kills(events: Iterable[Mapping[str, Any]]) -> int:
    """Reallocations of tasks taken from a robot while it was down: after its
    `robot_failure` (killed, or exited by itself) and before its `robot_restart`."""
    down: set[str] = set()
    count = 0
    for e in events:
        kind = e["kind"]
        if kind == ev.ROBOT_FAILURE:
            down.add(str(e["robot"]))
        elif kind == ev.ROBOT_RESTART:
            down.discard(str(e["robot"]))
        elif kind == ev.REALLOCATION and str(e.get("from_robot")) in down:
            count += 1
    return count


def user_outcomes(events: Iterable[Mapping[str, Any]]) -> dict[str, str]:
    """The counted outcome of each user task (group tasks included, their members not)."""
    user: set[str] = set()
    out: dict[str, str] = {}
    for e in events:
        if e["kind"] == ev.TASK_INTRODUCED and _user_task(e):
            user.add(str(e["task"]))
        elif e["kind"] == ev.TASK_OUTCOME and str(e["task"]) in user:
            out[str(e["task"])] = ev.counted_outcome(e)
    return out


def run_row(job: Job, summary: Mapping[str, Any] | None,
            events: Sequence[Mapping[str, Any]], exit_code: int | None,
            run_dir: Path | None) -> dict[str, Any]:
    """One row of comparison.csv (figures None when the run left no summary)."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(allocator=job.allocator, seed=job.seed, exit_code=exit_code,
               run_dir=str(run_dir) if run_dir is not None else None)
    if summary is None:
        return row
    outcomes = user_outcomes(events)
    introduced = len(outcomes)
    messages = summary.get("messages", {})
    total, total_bytes = int(messages.get("total", 0)), int(messages.get("total_bytes", 0))
    waits = start_waits(events)
    distance = summary.get("distance_m")
    row.update(
        sim_time_s=summary.get("sim_time_s"), tasks_introduced=introduced,
        tasks_completed=sum(1 for o in outcomes.values() if o == ev.COMPLETED),
        wait_mean_s=round(statistics.fmean(waits), 3) if waits else None,
        distance_m=distance.get("total") if isinstance(distance, Mapping) else None,
        messages=total, bytes=total_bytes,
        messages_per_task=round(total / introduced, 3) if introduced else None,
        bytes_per_task=round(total_bytes / introduced, 1) if introduced else None,
        group_tasks_completed=int(summary.get("group_tasks_completed", 0)),
        reallocations_after_kills=reallocations_after_kills(events),
        unachievable=sum(1 for o in outcomes.values() if o == ev.UNACHIEVABLE),
        wall_time_s=summary.get("wall_time_s"), events_sha256=summary.get("events_sha256"),
    )
    return row


def error_row(job: Job, error: BaseException) -> dict[str, Any]:
    """The row of a run that raised instead of giving its row: no exit code, no figures,
    the error."""
    row = run_row(job, None, [], None, None)
    row["error"] = f"{type(error).__name__}: {error}"
    return row


class Pending(Protocol):
    """A run under way (a thread pool's or a Dask cluster's future)."""

    def result(self) -> dict[str, Any]: ...


def rows_in_order(jobs: Sequence[Job], submit: Callable[[Job], Pending],
                  on_row: Callable[[dict[str, Any]], None] | None = None,
                  ) -> list[dict[str, Any]]:
    """Every job submitted at once, then the rows taken in job order, wherever the runs
    went; a run that raised gets its `error_row`, so the others' rows are kept. `on_row`
    sees each row as it is taken."""
    pending = [submit(job) for job in jobs]
    rows = []
    for job, run in zip(jobs, pending, strict=True):
        try:
            row = run.result()
        except Exception as exc:  # one run lost (e.g. its worker died) spoils no other
            row = error_row(job, exc)
        if on_row is not None:
            on_row(row)
        rows.append(row)
    return rows


# -- over seeds (pure) -------------------------------------------------------------------------


def mean_std(values: Iterable[Any]) -> tuple[float | None, float | None, int]:
    """Mean and sample standard deviation (n - 1; 0 for a single value) of the values that
    are there, and how many there were; (None, None, 0) for none."""
    vals = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    if not vals:
        return None, None, 0
    std = statistics.stdev(vals) if len(vals) > 1 else 0.0
    return statistics.fmean(vals), std, len(vals)


def by_allocator(rows: Sequence[Mapping[str, Any]],
                 order: Sequence[str] = ALLOCATOR_NAMES) -> list[dict[str, Any]]:
    """Per allocator (in `order`, then any other in name order): the number of runs with a
    summary and, for each metric, its (mean, std) over them."""
    names = [a for a in order if any(r["allocator"] == a for r in rows)]
    names += sorted({str(r["allocator"]) for r in rows} - set(names))
    out = []
    for name in names:
        group = [r for r in rows if r["allocator"] == name and r["sim_time_s"] is not None]
        stats: dict[str, Any] = {"allocator": name, "runs": len(group)}
        for key, _ in METRICS:
            mean, std, _n = mean_std(r[key] for r in group)
            stats[key] = (mean, std)
        out.append(stats)
    return out


def _cell(pair: tuple[float | None, float | None]) -> str:
    mean, std = pair
    if mean is None or std is None:
        return "-"
    digits = 0 if abs(mean) >= 100 else 1 if abs(mean) >= 10 else 2
    return f"{mean:.{digits}f} ± {std:.{digits}f}"


def format_table(stats: Sequence[Mapping[str, Any]]) -> str:
    """One line per metric, one column per allocator: mean ± std over its runs."""
    head = ("", *(f"{s['allocator']} ({s['runs']} run{'' if s['runs'] == 1 else 's'})"
                  for s in stats))
    rows = [head, *[(label, *(_cell(s[key]) for s in stats)) for key, label in METRICS]]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join("  ".join([r[0].ljust(widths[0]),
                                *(c.rjust(w) for c, w in zip(r[1:], widths[1:], strict=True))])
                     for r in rows)


# -- files and processes -----------------------------------------------------------------------


def write_csv(rows: Sequence[Mapping[str, Any]], path: Path) -> None:
    write_rows(rows, path, COLUMNS)


def plot_comparison(rows: Sequence[Mapping[str, Any]], stats: Sequence[Mapping[str, Any]],
                    path: Path, title: str, reference: str = "optimal") -> Path:
    """One panel per metric: a bar per allocator (mean, ± std) and a dot per run; the mean
    of the `reference` allocator (the exact central assignment), when it ran, as a dashed
    line across each panel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from experiments.plots import save

    colours = ("#1c7ed6", "#f08c00", "#2f9e44", "#ae3ec9", "#e03131")
    fig, axes = plt.subplots(2, 4, figsize=(14, 6.5), dpi=100)
    names = [str(s["allocator"]) for s in stats]
    for ax, (key, label) in zip(axes.flat, METRICS, strict=True):
        for i, s in enumerate(stats):
            mean, std = s[key]
            colour = colours[i % len(colours)]
            if mean is not None:
                ax.bar(i, mean, yerr=std, color=colour, alpha=0.55, capsize=4)
            dots = [r[key] for r in rows if r["allocator"] == s["allocator"]
                    and r[key] is not None]
            ax.scatter([i] * len(dots), dots, s=12, color=colour, zorder=3)
            if s["allocator"] == reference and mean is not None and len(stats) > 1:
                ax.axhline(mean, color="black", linestyle="--", linewidth=0.8, zorder=2)
        ax.set_xticks(range(len(names)), names)
        ax.set_title(label, fontsize="medium")
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    return save(fig, path)


def _reused_row(job: Job, out: Path, until_s: float, task_interval: float,
               own: tuple[str, Mapping[str, Any]], kills: Sequence[str], restarts: Sequence[str],
               world: str) -> dict[str, Any] | None:
    """The row of a finished run `--resume` may reuse for this job (None: run it)."""
    from experiments.compare_resume import expected_config, reusable_run

    expected = expected_config(
        allocator=job.allocator.removesuffix(REFINED), refine=job.allocator.endswith(REFINED),
        seed=job.seed, until_s=until_s, task_interval_s=task_interval,
        kills=kills, restarts=restarts, world=world, experiment=own[0], own=own[1])
    run_dir, _why = reusable_run(out / job.label(), expected)
    if run_dir is None:
        return None
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    return run_row(job, summary, ev.read_events(run_dir / "events.jsonl"), 0, run_dir)


def run_one(job: Job, *, out: Path, until_s: float, extra: Sequence[str],
            pin: bool, experiment: str = "longterm") -> dict[str, Any]:
    """Run the experiment once as its own process; its row."""
    code, run_dir, summary = run_experiment(
        experiment, out / job.label(), until_s=until_s, seed=job.seed,
        options=job.allocator_args(), extra=extra, pin=pin, log_name="compare.log")
    events: list[dict[str, Any]] = []
    if run_dir is not None and summary is not None:
        events = ev.read_events(run_dir / "events.jsonl")
    return run_row(job, summary, events, code, run_dir)


@contextmanager
def in_threads(jobs: int) -> Iterator[Submit]:
    """Runs on this machine, `jobs` at a time (each run is a process of its own)."""
    with ThreadPoolExecutor(max_workers=jobs) as pool:

        def submit(fn: Callable[[Any], Any], arg: Any, /) -> Any:
            return pool.submit(fn, arg)

        yield submit


def _span(seconds: float) -> str:
    if seconds >= 3600.0:
        return f"{seconds / 3600.0:g} h"
    return f"{seconds / 60.0:g} min" if seconds >= 60.0 else f"{seconds:g} s"


def parse_allocators(text: str, refine: bool = False) -> list[str]:
    """The allocators to compare, in order; with `refine` each consensus allocator is
    followed by its refined form."""
    from murdoch.allocators import ALLOCATORS
    from murdoch.plugin import PluginError

    try:
        ALLOCATORS.check()
    except PluginError as exc:
        raise click.UsageError(str(exc)) from None
    names = [a.strip() for a in text.split(",") if a.strip()]
    unknown = [a for a in names if a not in COMPARABLE]
    if not names or unknown:
        raise click.BadParameter(
            f"expected allocators among {', '.join(COMPARABLE)} (comma-separated), "
            f"got {text!r}", param_hint="--allocators")
    if refine:
        names = [n for a in names
                 for n in ((a, a + REFINED) if a in REFINABLE else (a,))]
    return list(dict.fromkeys(names))


def _run_options(experiment: str, world: str | None, task_interval: float,
                 own: tuple[list[str], dict[str, Any]],
                 kills: Sequence[str], restarts: Sequence[str], metric_terms: str,
                 until_s: float) -> tuple[list[str], dict[str, Any]]:
    """The options every run gets alike, checked before anything runs; with the
    experiment's own entries of config.json."""
    from experiments.plugin import RunOptions
    from experiments.run_checks import RunSetupError, check_schedule, load_run_world

    plugin = experiments()[experiment]
    try:
        spec = load_run_world(world or plugin.world)
        check_schedule(robots=[r.name for r in spec.robots], duration_s=until_s,
                       kills=[parse_at(k) for k in kills],
                       restarts=[parse_at(r) for r in restarts], world=world or plugin.world)
    except RunSetupError as exc:
        raise click.UsageError(str(exc)) from exc
    config = plugin.config(plugin.check(spec, RunOptions(until_s, 0, task_interval,
                                                         own=own[1])))
    extra = ["--task-interval", f"{task_interval:g}", *own[0]]
    for k in kills:
        extra += ["--kill", k]
    for r in restarts:
        extra += ["--restart", r]
    if metric_terms:
        extra += ["--metric", metric_terms]
    if world:
        extra += ["--world", world]
    return extra, config


@click.command("compare")
@click.argument("experiment", type=click.Choice(supporting("compare")))
@click.option("--allocators", default=None, show_default="every one the experiment supports",
              help="Allocators to compare, comma-separated; cbba+refine, cbga+refine: "
                   "with the robots' improvement phase (murdoch run --refine).")
@click.option("--refine", is_flag=True,
              help="Also run the refined form of every consensus allocator listed, next to "
                   "the plain one.")
@click.option("--seeds", default="1-5", show_default=True, help="Seeds: 1,2,3 or 1-5.")
@click.option("--sim-hours", type=float, default=None, help="Simulated hours of every run.")
@click.option("--until", "until", default=None, show_default="3h",
              help="Simulated span of every run, e.g. 3h, 90m.")
@click.option("--jobs", type=click.IntRange(1, 64), default=JOBS, show_default=True,
              help="Runs at a time (each its own runner and robot processes).")
@click.option("--dask", "dask_address", default=None, metavar="tcp://HOST:PORT",
              help="Run on the workers of this Dask scheduler instead of --jobs at a time "
                   "here (pip install 'murdoch[dask]'; each worker writes its runs under "
                   "--out on its own filesystem; the rows come back here).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path("runs/compare"), show_default=True)
@click.option("--world", default=None,
              help="World name or .toml (default: the experiment's).")
@click.option("--task-interval", type=float, default=240.0, show_default=True,
              help="Mean simulated seconds between new tasks.")
@click.option("--kill", "kills", multiple=True,
              help="Kill a robot process in every run: ROBOT@TIME ('busy' = one holding a "
                   "task).")
@click.option("--restart", "restarts", multiple=True,
              help="Start it again in every run: ROBOT@TIME.")
@click.option("--metric", "metric_terms", default="",
              help="Passed to every run: terms added to the robots' task metrics.")
@click.option("--resume", is_flag=True,
              help="Reuse the finished runs under --out made with exactly these options "
                   "(a lockstep run repeats exactly); run only the others.")
@click.option("--no-plots", is_flag=True,
              help="The runs draw no plots of their own (murdoch run --no-plots; murdoch "
                   "report RUN_DIR draws them); the comparison's figure is drawn.")
@click.pass_context
def compare(ctx: click.Context, experiment: str, allocators: str | None, refine: bool,
            seeds: str,
            sim_hours: float | None,
            until: str | None, jobs: int, out: Path, world: str | None, task_interval: float,
            kills: tuple[str, ...], restarts: tuple[str, ...],
            metric_terms: str, dask_address: str | None, resume: bool, no_plots: bool,
            **values: Any) -> None:
    """Run EXPERIMENT with each allocator on each seed; CSV, figure and a table."""
    names = parse_allocators(allocators or ",".join(_supported(experiment)), refine)
    unsupported = [n for n in names if n.removesuffix(REFINED) not in _supported(experiment)]
    if unsupported:
        raise click.BadParameter(f"{experiment} supports {', '.join(_supported(experiment))};"
                                 f" found {', '.join(unsupported)}", param_hint="--allocators")
    seed_list = parse_seeds(seeds)
    if sim_hours is not None and until is not None:
        raise click.UsageError("give --sim-hours or --until, not both")
    until_s = sim_hours * 3600.0 if sim_hours is not None else parse_duration_s(until or "3h")
    if until_s <= 0:
        raise click.BadParameter(f"expected a positive span, got {until_s:g} s",
                                 param_hint="--sim-hours" if sim_hours is not None
                                 else "--until")
    if metric_terms:
        from experiments.run_cli import _metric_terms

        _metric_terms(metric_terms)  # a bad term is refused before anything runs
    every = experiments()
    own = passthrough_args(every[experiment], every, values, ctx)
    extra, config = _run_options(experiment, world, task_interval, own, kills, restarts,
                                 metric_terms, until_s)
    if no_plots:  # (how a run's output is drawn, not what it ran: --resume reuses either)
        extra.append("--no-plots")
    if dask_address is not None:
        out = out.absolute()  # the same path on every worker (a shared filesystem's)
    place = _where(dask_address, jobs)
    todo = [Job(a, s) for s in seed_list for a in names]
    # several runs on one host would all pin their serving threads to the same CPU
    run = functools.partial(run_one, out=out, until_s=until_s, extra=extra,
                            pin=jobs == 1 and dask_address is None, experiment=experiment)
    from murdoch.dask_jobs import DaskUnavailable

    reused: list[dict[str, Any]] = []
    if resume and not metric_terms:
        for job in todo:
            row = _reused_row(job, out, until_s, task_interval, (experiment, config), kills,
                              restarts, world or every[experiment].world)
            if row is not None:
                click.echo(f"  {job.label()}: reused {row['run_dir']}")
                reused.append(row)
        done = {(r["allocator"], r["seed"]) for r in reused}
        todo = [job for job in todo if (job.allocator, job.seed) not in done]
    try:
        with place as submit:
            out.mkdir(parents=True, exist_ok=True)
            click.echo(f"{len(todo)} runs of {experiment} for {until_s:g} s simulated "
                       f"({', '.join(names)} x seeds {', '.join(map(str, seed_list))}), "
                       + (f"on the Dask cluster at {dask_address}" if dask_address
                          else f"{jobs} at a time") + f", into {out}")
            rows = reused + rows_in_order(todo, functools.partial(submit, run), _report)
    except (DaskUnavailable, OSError) as exc:
        raise click.ClickException(str(exc)) from None
    rows.sort(key=lambda r: (names.index(r["allocator"]), int(r["seed"])))
    write_csv(rows, out / "comparison.csv")
    stats = by_allocator(rows, names)
    plot = plot_comparison(rows, stats, out / "comparison.png",
                           f"{experiment}: {_span(until_s)} simulated, seeds {seeds}, "
                           "mean ± std over seeds")
    click.echo(format_table(stats))
    click.echo(f"wrote {out / 'comparison.csv'}, {plot}")
    from experiments.compare_paired import against_reference

    table = against_reference(rows, METRICS, out, f"{experiment}: {_span(until_s)} simulated,"
                              f" seeds {seeds}, seed by seed against optimal")
    if table is not None:
        click.echo(f"{table}\nwrote {out / 'comparison-paired.csv'}, "
                   f"{out / 'comparison-paired.png'}")
    failed = [r for r in rows if r["exit_code"] != 0]
    if failed:
        click.echo(f"error: {len(failed)} run(s) did not end cleanly: "
                   + ", ".join(_why(Job(r["allocator"], r["seed"]), r, out) for r in failed),
                   err=True)
        sys.exit(1)


def _supported(experiment: str) -> list[str]:
    """The allocators `experiment` may run with (`Supports`)."""
    from experiments.run_tasks import supported_allocators

    return supported_allocators(experiments()[experiment])


def _where(dask_address: str | None, jobs: int) -> AbstractContextManager[Submit]:
    """Where the runs go: the Dask cluster at `dask_address` (checked here, before anything
    runs), else `jobs` at a time on this machine."""
    if dask_address is None:
        return in_threads(jobs)
    from murdoch.dask_jobs import check_address, connected

    try:
        check_address(dask_address)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--dask") from None
    if jobs != JOBS:
        raise click.BadParameter(
            f"--jobs counts runs at a time on this machine; with --dask the cluster's workers "
            f"run them (one per worker thread): expected --jobs {JOBS} or none, got {jobs}",
            param_hint="--jobs")
    return connected(dask_address)


def _report(row: Mapping[str, Any]) -> None:
    label = Job(row["allocator"], row["seed"]).label()
    if row["error"] is not None:
        click.echo(f"  {label}: {row['error']}")
        return
    click.echo(f"  {label}: exit {row['exit_code']}, completed {row['tasks_completed']}, "
               f"group {row['group_tasks_completed']} ({row['wall_time_s']} s wall)")


def _why(job: Job, row: Mapping[str, Any], out: Path) -> str:
    if row["error"] is not None:
        return f"{job.label()} ({row['error']})"
    return f"{job.label()} (exit {row['exit_code']}, see {out}/{job.label()}/compare.log)"


add_passthrough_params(compare, experiments())
