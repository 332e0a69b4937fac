"""`murdoch soak EXPERIMENT`: run the team for a long span under seeded faults, check that
nothing was lost, and write a soak report (`soak.json`, `soak.md`, `plots/soak-*.png`).

`murdoch soak-report RUN_DIR` rebuilds the report of a finished soak run from its files.
Exit status: 0 every invariant held, 3 an invariant broke, 1 the run did not complete.
"""

from __future__ import annotations

import json
import random
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from experiments.durations import parse_duration_s
from experiments.option_params import add_params, own_values
from experiments.registry import experiments, supporting
from experiments.soak.faults import (
    FaultFileError,
    FaultMix,
    draw_schedule,
    fault_to_dict,
    load_schedule,
)

INVARIANT_BROKEN = 3


def _span(text: str) -> tuple[float, float]:
    lo, sep, hi = text.partition("-")
    try:
        a, b = parse_duration_s(lo), parse_duration_s(hi if sep else lo)
    except click.BadParameter as exc:
        raise click.BadParameter(f"expected MIN-MAX such as 30s-5m, got {text!r}") from exc
    if b < a:
        raise click.BadParameter(f"expected MIN-MAX with MIN <= MAX, got {text!r}")
    return a, b


_Command = TypeVar("_Command", bound=Callable[..., Any])


def _rate_and_span(
    rate_flag: str, rate: float, span_flag: str, span: str, span_help: str,
) -> Callable[[_Command], _Command]:
    """The two options of a kind of fault: how many per simulated hour, and for how long
    (a MIN-MAX span, read with `_span`)."""

    def add(command: _Command) -> _Command:
        command = click.option(span_flag, default=span, show_default=True,
                               help=span_help)(command)
        return click.option(rate_flag, type=click.FloatRange(min=0), default=rate,
                            show_default=True)(command)

    return add


@click.command()
@click.argument("experiment", type=click.Choice(supporting("soak")))
@click.option("--sim-hours", type=click.FloatRange(min=0.01), default=24.0, show_default=True,
              help="Simulated hours to run.")
@click.option("--seed", type=int, default=1, show_default=True,
              help="Fixes the world, the tasks and the fault schedule.")
@click.option("--world", "world_name", default=None,
              help="World name or .toml (default: the experiment's).")
@click.option("--faults", "faults_opt", default="random", show_default=True,
              help="random (drawn from the seed), none, or a JSON file of faults.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("runs"),
              show_default=True)
@click.option("--speedup", type=float, default=0.0, show_default=True,
              help="0 = lockstep (repeats exactly); > 0 = real time x speedup (loss faults).")
@_rate_and_span("--kills-per-hour", 1.0, "--kill-down", "30s-5m",
                "How long a killed robot stays down before its restart (MIN-MAX).")
@_rate_and_span("--freezes-per-hour", 1.0, "--freeze-for", "5s-60s",
                "How long a frozen robot stays stopped (MIN-MAX, simulated).")
@click.option("--switch-offs", type=click.IntRange(min=0), default=1, show_default=True,
              help="Robots switched off for good part-way through.")
@_rate_and_span("--charger-outages-per-hour", 0.5, "--charger-outage", "5m-20m",
                "How long a charger is off (MIN-MAX).")
@click.option("--bursts", type=click.IntRange(min=0), default=1, show_default=True,
              help="Bursts of tasks far beyond the team's capacity.")
@click.option("--burst-size", type=click.IntRange(min=1, max=1000), default=20,
              show_default=True)
@click.option("--loss", type=click.FloatRange(0.0, 0.5), default=0.02, show_default=True,
              help="Real time only: fraction of MURDOCH datagrams each receiver drops.")
@click.option("--delay", type=click.FloatRange(0.0, 5.0), default=0.05, show_default=True,
              help="Real time only: most wall seconds a received datagram is held back.")
@click.option("--task-interval", type=float, default=240.0, show_default=True,
              help="Mean simulated seconds between new tasks.")
@click.option("--realloc-bound", type=click.FloatRange(min=0.0), default=None,
              help="Simulated seconds within which a killed or frozen holder's task must be "
                   "back at auction or ended (default: the contract timeout + a renewal "
                   "period + a bid window).")
@click.option("--memory-slope-limit", type=click.FloatRange(min=0.0), default=2.0,
              show_default=True, help="MiB per simulated hour a process's memory may grow (a host "
                   "process's, per robot).")
@click.option("--memory-every", type=click.FloatRange(min=0.1), default=5.0,
              show_default=True, help="Wall seconds between memory samples.")
@click.option("--no-record", is_flag=True, help="Write no run.mcap (the dead-controller "
              "check then has no poses and is reported as not checked).")
@click.option("--meshcat", is_flag=True, help="Serve the live 3-D view on 127.0.0.1.")
@click.pass_context
def soak(ctx: click.Context, experiment: str, sim_hours: float, seed: int,
         world_name: str | None, faults_opt: str, out: Path,
         speedup: float, kills_per_hour: float, kill_down: str, freezes_per_hour: float,
         freeze_for: str, switch_offs: int, charger_outages_per_hour: float,
         charger_outage: str, bursts: int, burst_size: int, loss: float, delay: float,
         task_interval: float, realloc_bound: float | None, memory_slope_limit: float,
         memory_every: float, no_record: bool, meshcat: bool, **values: Any) -> None:
    """Run EXPERIMENT for --sim-hours under faults and check that nothing was lost (an
    experiment that ends by itself starts over for the whole span when it says how:
    boxpush puts the box back at its start each time it arrives, its --rounds 0)."""
    from experiments.run_cli import run_experiment
    from experiments.run_extras import RunExtras
    from experiments.soak.invariants import Limits
    from experiments.soak.monitor import SoakMonitor
    from experiments.soak.report import build_report, print_report
    from worlds import WorldError, load_world, world_path

    span_s = sim_hours * 3600.0
    every = experiments()
    own = own_values(every[experiment], every, values, ctx)
    for dest, value in every[experiment].supports.soak_options:
        if own.get(dest) is None:
            own[dest] = value
    world_name = world_name or every[experiment].world
    try:
        spec = load_world(world_path(world_name))
    except (FileNotFoundError, WorldError) as exc:
        raise click.BadParameter(str(exc), param_hint="--world") from exc
    robots = [r.name for r in spec.robots]
    mobile = [r.name for r in spec.robots if r.mobile]
    chargers = [c.name for c in spec.chargers]
    mix = FaultMix(
        kills_per_h=kills_per_hour, kill_down_s=_span(kill_down),
        freezes_per_h=freezes_per_hour, freeze_s=_span(freeze_for), switch_offs=switch_offs,
        charger_outages_per_h=charger_outages_per_hour,
        charger_outage_s=_span(charger_outage), bursts=bursts, burst_size=burst_size)
    if faults_opt == "random":
        faults = draw_schedule(random.Random(seed + 7), span_s, mobile, chargers, mix)
    elif faults_opt == "none":
        faults = []
    else:
        try:
            faults = load_schedule(Path(faults_opt), robots, chargers)
        except FaultFileError as exc:
            raise click.BadParameter(str(exc), param_hint="--faults") from exc
    limits = Limits.defaults(realloc_bound_s=realloc_bound,
                             memory_slope_mib_per_h=memory_slope_limit)
    lossy = speedup > 0 and loss > 0 and faults_opt != "none"
    soak_config: dict[str, Any] = {
        "soak": {
            "faults_option": faults_opt,
            "mix": mix.as_dict() if faults_opt == "random" else None,
            "bus_loss": {"loss": loss, "delay_s": delay} if lossy else None,
            "limits": limits.as_dict(),
        },
        "faults": [fault_to_dict(f) for f in faults],
    }
    monitor = SoakMonitor(limits, stream=sys.stdout)
    run_dir: list[Path] = []

    def started(root: Path) -> None:
        run_dir.append(root)
        monitor.start(root)

    extras = RunExtras(faults=tuple(faults), config=soak_config, burst_seed=seed + 11,
                       memory_every_s=memory_every, on_run_dir=started,
                       bus_loss=f"{loss},{delay},{seed + 13}" if lossy else None)
    click.echo(f"soak: {experiment}, {sim_hours:g} simulated hours, seed {seed}, "
               f"{len(faults)} scheduled faults")
    try:
        code = run_experiment(
            experiment=experiment, duration_s=span_s, speedup=speedup, seed=seed,
            meshcat=meshcat, out=out, world_name=world_name,
            task_interval_s=task_interval, kills=[], restarts=[], replay=False, own=own,
            pin_cpus=True, record=not no_record, extras=extras)
    finally:
        monitor.stop()
    if not run_dir:
        sys.exit(1)
    report = build_report(run_dir[0])
    print_report(report, click.echo)
    if not report["all_held"]:
        sys.exit(INVARIANT_BROKEN)
    sys.exit(0 if code == 0 else 1)


add_params(soak, experiments())


@click.command("soak-report")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print soak.json instead.")
def soak_report(run_dir: Path, as_json: bool) -> None:
    """Rebuild the soak report of RUN_DIR; exit 3 if an invariant broke."""
    from experiments.soak.report import build_report, print_report

    if not (run_dir / "events.jsonl").exists():
        raise click.BadParameter(f"{run_dir}: no events.jsonl (not a run directory)",
                                 param_hint="RUN_DIR")
    report = build_report(run_dir)
    if as_json:
        click.echo(json.dumps(report, indent=2))
    else:
        print_report(report, click.echo)
    if not report["all_held"]:
        sys.exit(INVARIANT_BROKEN)


