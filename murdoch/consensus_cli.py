"""`murdoch allocate` and `murdoch sweep`: the consensus allocators from the command line."""

from __future__ import annotations

import json
import os
import time
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

import click

from murdoch.consensus.cbga import TEAM_MODES, CbgaOptions
from murdoch.consensus.experiments import DEFAULT_AGENTS, EXPERIMENTS
from murdoch.consensus.refine import RefineOptions
from murdoch.consensus.scenario import COSTS, ScenarioError, load_scenario
from murdoch.consensus.sync_runner import allocate as run_allocation

# the `murdoch` group puts the directories of bundled scenarios here (the composition root
# knows where they are; this package does not)
SCENARIO_DIRS_KEY = "murdoch.scenario_dirs"


def _scenario_path(text: str) -> Path:
    from murdoch.consensus_table import resolve_scenario

    ctx = click.get_current_context()
    dirs = ctx.find_root().meta.get(SCENARIO_DIRS_KEY, ())
    try:
        return resolve_scenario(text, dirs)
    except LookupError as exc:
        raise click.BadParameter(str(exc), param_hint="SCENARIO") from exc


@click.command()
@click.argument("scenario", metavar="SCENARIO")
@click.option("--algorithm", type=click.Choice(["cbba", "cbga"]), default="cbba",
              show_default=True)
@click.option("--task-quitting/--no-task-quitting", default=True, show_default=True,
              help="CBGA: leave group tasks still incomplete after their quit_after.")
@click.option("--team-reward/--no-team-reward", default=True, show_default=True,
              help="CBGA: group-task bids count the team's value.")
@click.option("--team-mode", type=click.Choice(TEAM_MODES), default="bonus",
              show_default=True,
              help="CBGA team reward: 'bonus' adds team_reward * others / (L - 1) to a "
                   "group bid; 'total' bids the agent's gain for every member it completes "
                   "the task with (the paper's total value).")
@click.option("--cost", type=click.Choice(COSTS), default=None,
              help="How a task scores, overriding the scenario's 'cost': 'discount' "
                   "(reward * exp(-discount * delay)) or 'paper' (reward - (delay + "
                   "duration), the CBGA paper's eq. 8).  [default: the scenario's, "
                   "else discount]")
@click.option("--max-rounds", type=click.IntRange(1), default=1000, show_default=True)
@click.option("--engine", type=click.Choice(["compiled", "agents"]), default="compiled",
              show_default=True,
              help="CBBA and CBGA: the compiled run (same results; about 1.5 s to load "
                   "numba) or the agent-based reference (no start-up cost; slower on big "
                   "problems).")
@click.option("--refine", is_flag=True, default=False,
              help="After convergence, improve the plan by exchanges agreed through "
                   "consensus (closer to the optimum, more messages; see docs/consensus.md).")
@click.option("--refine-seed", type=int, default=0, show_default=True,
              help="With --refine: the seed that orders equal proposals.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def allocate(scenario: str, algorithm: str, task_quitting: bool, team_reward: bool,
             team_mode: str, cost: str | None, max_rounds: int, engine: str, refine: bool,
             refine_seed: int, as_json: bool) -> None:
    """Run CBBA or CBGA on SCENARIO in synchronous rounds and print the allocation.

    SCENARIO is a JSON file or the name of a bundled scenario (consensus-small,
    consensus-groups, consensus-equipment)."""
    from murdoch.consensus_table import COMPILE_NOTE, format_allocation, kernel_cache_warm

    path = _scenario_path(scenario)
    try:
        sc = load_scenario(path)
    except ScenarioError as exc:
        raise click.ClickException(str(exc)) from exc
    if cost is not None:
        sc = replace(sc, cost=cost)
    if engine == "compiled" and not kernel_cache_warm(algorithm):
        click.echo(COMPILE_NOTE.format(algorithm=algorithm.upper()), err=True)
    try:
        result = run_allocation(sc, algorithm,  # type: ignore[arg-type]
                                CbgaOptions(task_quitting, team_reward, team_mode=team_mode),
                                max_rounds,
                                compiled=engine == "compiled",
                                refine=RefineOptions(seed=refine_seed) if refine else False)
    except ValueError as exc:
        raise click.ClickException(f"{path}: {exc}") from exc
    out = result.to_json()
    if refine:
        # the improvement phase's share of the communication, and where it ran
        for key in ("refine", "engine", "engine_note"):
            if key in result.extra:
                out[key] = result.extra[key]
    if as_json:
        click.echo(json.dumps(out, indent=2))
        return
    engine_used = result.extra.get("engine", engine)
    title = (f"{algorithm.upper()} on {path.name}: {len(sc.agents)} agents, {len(sc.tasks)} "
             f"tasks ({engine_used} engine)")
    click.echo(format_allocation(out, title=title))
    if refine and "engine_note" in result.extra:
        click.echo(f"note: {result.extra['engine_note']}")


@click.command()
@click.option("--experiment", type=click.Choice([*EXPERIMENTS, "all"]), default="fig5",
              show_default=True)
@click.option("--agents", default=None,
              help="Agent counts, e.g. 1-10 or 2,5,10 (default: the paper's for the "
                   "experiment: 1-10, or 10 for fig7).")
@click.option("--runs", type=click.IntRange(1), default=100, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--jobs", type=click.IntRange(1), default=max(1, (os.cpu_count() or 1)),
              show_default="CPU count")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory (default runs/sweep-<experiment>-<UTC time>).")
@click.option("--refine", is_flag=True, default=False,
              help="Run every allocation with the improvement phase (variants are named "
                   "'... +refine').")
@click.option("--cost", type=click.Choice(COSTS), default="discount", show_default=True,
              help="How tasks score: 'discount' (100 * exp(-0.02 * delay)) or 'paper' "
                   "(100 - (delay + duration), the CBGA paper's eq. 8).")
@click.option("--team-mode", type=click.Choice(TEAM_MODES), default="bonus",
              show_default=True,
              help="How the team-reward variants bid: 'bonus' or 'total' (the paper's "
                   "total value of the group task).")
@click.option("--dask", "dask_address", default=None, metavar="tcp://HOST:PORT",
              help="Run the allocations on the workers of this Dask scheduler instead of "
                   "--jobs local processes (pip install 'murdoch[dask]'; same records).")
def sweep(experiment: str, agents: str | None, runs: int, seed: int, jobs: int,
          out: Path | None, refine: bool, cost: str, team_mode: str,
          dask_address: str | None) -> None:
    """Reproduce the CBGA paper's experiments: table (mean ± std) and figures."""
    from murdoch.consensus import plots
    from murdoch.consensus.sweep import (
        jobs_for,
        markdown_table,
        parse_agents,
        run_jobs,
        summarise,
        write_outputs,
    )

    names = list(EXPERIMENTS) if experiment == "all" else [experiment]
    if out is None:
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        out = Path("runs") / f"sweep-{experiment}-{stamp}"
    try:
        counts = {n: parse_agents(agents) if agents else DEFAULT_AGENTS[n] for n in names}
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--agents") from exc
    if dask_address is not None:
        from murdoch.dask_jobs import check_address

        try:
            check_address(dask_address)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--dask") from None
    all_jobs = [j for n in names
                for j in jobs_for(n, counts[n], runs, seed, refine, cost, team_mode)]
    where = f"on the Dask cluster at {dask_address}" if dask_address else f"in {jobs} process(es)"
    click.echo(f"{len(all_jobs)} allocations {where} -> {out}", err=True)
    t0 = time.monotonic()
    last = [0.0]

    def progress(done: int, total: int) -> None:
        now = time.monotonic()
        if now - last[0] > 5 or done == total:
            last[0] = now
            click.echo(f"  {done}/{total} ({now - t0:.0f} s)", err=True)

    from murdoch.dask_jobs import DaskUnavailable

    try:
        records = run_jobs(all_jobs, jobs, progress, dask_address=dask_address)
    except (DaskUnavailable, OSError) as exc:
        raise click.ClickException(str(exc)) from None
    rows = summarise(records)
    meta = {"experiments": names, "agents": {n: list(c) for n, c in counts.items()},
            "runs": runs, "seed": seed, "jobs": jobs, "refine": refine, "cost": cost,
            "team_mode": team_mode, "dask": dask_address,
            "wall_s": round(time.monotonic() - t0, 1)}
    files = write_outputs(out, records, rows, meta)
    for n in names:
        files += plots.plot_experiment(rows, n, out)
    click.echo(markdown_table(rows))
    for f in files:
        click.echo(f"wrote {f}")


@click.command("sweep-compare")
@click.argument("base", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("other", required=False,
                type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--metric", "metrics", multiple=True, default=("score", "steps"),
              show_default=True, type=click.Choice(["score", "steps", "pairwise_steps",
                                                    "messages", "bytes", "bytes_dense"]),
              help="What to compare (repeatable).")
@click.option("--agents", default=None, help="Only these agent counts, e.g. 5,10.")
def sweep_compare(base: Path, other: Path | None, metrics: tuple[str, ...],
                  agents: str | None) -> None:
    """Paired differences (mean ± standard error, runs up/down/same) between sweeps.

    With one sweep directory, each variant against its experiment's first variant; with
    two, OTHER's runs against BASE's (same experiment, variant, agents and run)."""
    import csv

    from murdoch.consensus.compare import against_first, between, markdown
    from murdoch.consensus.sweep import parse_agents

    def rows(d: Path) -> list[dict[str, str]]:
        f = d / "runs.csv"
        if not f.is_file():
            raise click.BadParameter(f"{d}: no runs.csv (expected a `murdoch sweep` output "
                                     "directory)", param_hint="BASE/OTHER")
        with f.open(encoding="utf-8", newline="") as fh:
            out = list(csv.DictReader(fh))
        missing = [m for m in metrics if out and m not in out[0]]
        if missing:
            raise click.BadParameter(f"{f}: no column {', '.join(missing)} (a sweep made "
                                     "before it was recorded)", param_hint="--metric")
        return out

    try:
        counts = parse_agents(agents) if agents else None
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--agents") from exc
    order = {name: [v.name for v in variants] for name, variants in EXPERIMENTS.items()}
    first = rows(base)
    second = rows(other) if other is not None else None
    for metric in metrics:
        if second is None:
            table = against_first(first, metric, order)
        else:
            table = between(first, second, metric, reference=base.name)
        click.echo(markdown(table, counts))
