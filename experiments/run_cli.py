"""`murdoch run EXPERIMENT`: one command that runs an experiment end to end.

The runner process holds the simulation and the Player device server (its serving thread),
starts one `murdoch-robot` process per endpoint (robots joining MURDOCH over loopback
multicast on a port of their own, `behaviors.murdoch_link`), and is itself the user: it
introduces the experiment's tasks through a MURDOCH node, logs every auction message it
hears, and writes the run directory through `experiments.recorder.RunRecorder`. Lockstep is
used when running as fast as possible (speedup 0), so a seeded run repeats.

What differs between experiments comes from their plug-in (`experiments.registry`: the
built-in ones and those of installed packages, each with its own options, offered here
from their declarations, `experiments.option_params`); the
processes are described as data (`experiments.supervisor.ProcessSpec`, listed in
config.json); `run_experiment` puts the pieces together (`experiments.run_parts`).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from experiments.durations import parse_at, parse_duration_s
from experiments.option_params import add_params, own_values
from experiments.registry import experiments
from experiments.run_checks import LIVE_RATE_HZ
from experiments.supervisor import RobotProcess, RobotSupervisor
from experiments.supervisor import start_robot as _start_robot
from experiments.supervisor import stop_robot as _stop_robot
from murdoch.allocators import ALLOCATORS, REFINABLE

if TYPE_CHECKING:
    from experiments.run_extras import RunExtras

__all__ = ["RobotProcess", "RobotSupervisor", "_start_robot", "_stop_robot", "parse_at",
           "parse_duration_s", "run", "run_experiment"]

DEFAULT_DURATION_S = 600.0


def parse_place(text: str) -> tuple[str, tuple[str, ...]]:
    """'r2=ip netns exec robots' -> ('r2', ('ip', 'netns', 'exec', 'robots'))."""
    import shlex

    robot, sep, prefix = text.partition("=")
    try:
        words = tuple(shlex.split(prefix))
    except ValueError as exc:
        raise click.BadParameter(f"{text!r}: {exc}; expected ROBOT=COMMAND PREFIX",
                                 param_hint="--place") from None
    if not sep or not robot.strip() or not words:
        raise click.BadParameter(f"expected ROBOT=COMMAND PREFIX such as 'r2=ip netns exec "
                                 f"robots', got {text!r}", param_hint="--place")
    return robot.strip(), words


class PerProcess(click.ParamType):
    """`--robots-per-process`: a whole number of at least 1, or ``auto`` (None)."""

    name = "K|auto"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> int | None:
        if value is None or isinstance(value, int):
            return value
        text = str(value).strip()
        if text == "auto":
            return None
        if text.isascii() and text.isdigit() and int(text) >= 1:
            return int(text)
        self.fail(f"expected a whole number of at least 1 or 'auto', found {text!r}", param,
                  ctx)


@click.command()
@click.argument("experiment", type=click.Choice(sorted(experiments())))
@click.option("--sim-hours", type=float, default=None, help="Simulated hours to run.")
@click.option("--until", "until", default=None, show_default="10m",
              help="Simulated duration, e.g. 90m, 2h.")
@click.option("--speedup", type=float, default=None, show_default="0, or 10 with --meshcat",
              help="Simulated seconds per wall second; 0 = as fast as possible (lockstep: the "
                   "run repeats exactly); above 0 paced by the wall clock.")
@click.option("--seed", type=int, default=1, show_default=True)
@click.option("--meshcat", is_flag=True, help="Serve the live 3-D view on 127.0.0.1.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("runs"),
              show_default=True)
@click.option("--world", default=None, help="World name, .toml or .world (default: experiment's).")
@click.option("--task-interval", type=click.FloatRange(min=0, min_open=True), default=None,
              show_default="240 for six robots, shorter for a bigger team",
              help="Mean simulated seconds between new tasks (default: 240 s for a team of "
                   "up to six mobile robots, 240 x 6 / N for N of them).")
@click.option("--kill", "kills", multiple=True,
              help="Kill a robot process: ROBOT@TIME (ROBOT 'busy' = one holding a task).")
@click.option("--restart", "restarts", multiple=True,
              help="Start a killed robot again: ROBOT@TIME ('busy' = the last one killed so).")
@click.option("--metric", "metric_terms", default="",
              help="Terms added to every robot's task metrics: distance (metres to where the "
                   "task is), specialist (fewer spare resources bid higher), comma-separated.")
@click.option("--allocator", type=click.Choice(list(ALLOCATORS)), default="murdoch",
              show_default=True,
              help="The team's allocator, the same on the runner and on every robot: "
                   + "; ".join(f"{a.name}: {a.summary}" for a in ALLOCATORS.values()) + ".")
@click.option("--refine", is_flag=True,
              help="cbba, cbga: the robots improve each settled plan by exchanges agreed "
                   "among them before claiming (docs/allocators.md); off by default.")
@click.option("--no-replay", is_flag=True, help="Do not write replay.html.")
@click.option("--no-plots", is_flag=True,
              help="Do not draw plots/*.png at the end (about a second of CPU a run; "
                   "`murdoch report RUN_DIR` draws them later).")
@click.option("--pipelined/--no-pipelined", default=True, show_default=True,
              help="Lockstep: the server sends each round before it steps and computes the "
                   "next one while the robots work (their commands act one tick later).")
@click.option("--robot-nice", type=click.IntRange(0, 19), default=0, show_default=True,
              help="Niceness of the robot processes: above 0 the simulator's serving thread, "
                   "which every robot waits on, wins the CPU when both are ready to run.")
@click.option("--key", default=None,
              help="Team key for the run's MURDOCH traffic (default: $MURDOCH_TEAM_KEY, else a "
                   "fresh key per run, handed to the robots through their environment).")
@click.option("--pin-cpus/--no-pin-cpus", default=True, show_default=True,
              help="Give the simulator's serving thread a CPU of its own and run everything "
                   "else (robots, runner) on the others (Linux, at least two CPUs).")
@click.option("--record-rate", type=click.FloatRange(min=0.01, max=10.0), default=2.0,
              show_default=True,
              help="Samples per simulated second of poses and sensors in run.mcap.")
@click.option("--no-record", is_flag=True,
              help="Write no run.mcap (and so no replay.html).")
@click.option("--trails", type=click.IntRange(0, 5000), default=0, show_default=True,
              help="--meshcat: draw a trail of each robot's last N positions.")
@click.option("--lasers", is_flag=True, help="--meshcat: draw the robots' laser rays.")
@click.option("--live-rate", type=click.FloatRange(min=0.2, max=50.0), default=LIVE_RATE_HZ,
              show_default=True,
              help="--meshcat: frames per wall-clock second sent to the live view; fewer for "
                   "a slow machine or browser (the run and its recording are the same).")
@click.option("--transport", type=click.Choice(["multicast", "zenoh"]), default="multicast",
              show_default=True,
              help="The team's MURDOCH bus: loopback UDP multicast, or Zenoh with this process "
                   "as the hub (pip install 'murdoch[zenoh]'); lockstep works on both.")
@click.option("--bind", default="127.0.0.1", show_default=True,
              help="Address the Player server (and a Zenoh hub) listen on; robots are told "
                   "it. Another address only for robots on other hosts (--place).")
@click.option("--place", "places", multiple=True, metavar="ROBOT=PREFIX",
              help="Start ROBOT's process through a command prefix, e.g. "
                   "'r2=ip netns exec robots' or 'r2=ssh lab-host-2' (needs --transport zenoh; "
                   "repeatable; see docs/experiments.md).")
@click.option("--robots-per-process", type=PerProcess(), default="auto", show_default=True,
              help="Robots to a process: 1 runs a murdoch-robot process per robot; K above 1 "
                   "runs ceil(N/K) host processes of K robots, each robot in a thread of its "
                   "own (less memory per robot; no pausing one robot alone); auto: the team "
                   "spread over one host per CPU left to the robots (all CPUs but the "
                   "serving thread's), at most 100 robots to a host; 1 where a robot is "
                   "placed elsewhere or paused alone.")
@click.pass_context
def run(ctx: click.Context, experiment: str, sim_hours: float | None, until: str | None,
        speedup: float | None, seed: int,
        meshcat: bool, out: Path, world: str | None, task_interval: float | None,
        kills: tuple[str, ...], restarts: tuple[str, ...], metric_terms: str, allocator: str,
        refine: bool, no_replay: bool, no_plots: bool,
        pipelined: bool, robot_nice: int, key: str | None, pin_cpus: bool,
        record_rate: float, no_record: bool, trails: int, lasers: bool,
        live_rate: float, transport: str, bind: str, places: tuple[str, ...],
        robots_per_process: int | None, **values: Any) -> None:
    """Run EXPERIMENT end to end and leave a run directory behind (an experiment's own
    options are named after it in their help)."""
    from experiments.run_checks import RunSetupError, check_out_dir, effective_speedup
    from murdoch.plugin import PluginError

    try:
        ALLOCATORS.check()
    except PluginError as exc:
        raise click.UsageError(str(exc)) from None
    if sim_hours is not None and until is not None:
        raise click.UsageError("give --sim-hours or --until, not both")
    if refine and allocator not in REFINABLE:
        raise click.UsageError(f"--refine is for the consensus allocators "
                               f"({', '.join(REFINABLE)}), not --allocator {allocator}")
    every = experiments()
    duration_s = (sim_hours * 3600.0 if sim_hours is not None
                  else parse_duration_s(until) if until is not None else DEFAULT_DURATION_S)
    try:
        check_out_dir(out)
        code = run_experiment(
            experiment=experiment, duration_s=duration_s,
            speedup=effective_speedup(speedup, meshcat), seed=seed,
            meshcat=meshcat, out=out, world_name=world or every[experiment].world,
            task_interval_s=task_interval, kills=[parse_at(k) for k in kills],
            restarts=[parse_at(r) for r in restarts], replay=not no_replay,
            plots=not no_plots, own=own_values(every[experiment], every, values, ctx),
            pipelined=pipelined, robot_nice=robot_nice, pin_cpus=pin_cpus, key=key,
            record=not no_record, record_rate_hz=record_rate, trails=trails, lasers=lasers,
            live_rate_hz=live_rate, metric_terms=_metric_terms(metric_terms),
            allocator=allocator, refine=refine, transport=transport, bind=bind,
            placements=tuple(parse_place(p) for p in places),
            robots_per_process=robots_per_process,
        )
    except RunSetupError as exc:
        click.echo(f"murdoch run: {exc}", err=True)
        sys.exit(exc.exit_code)
    sys.exit(code)


def _metric_terms(text: str) -> tuple[str, ...]:
    from behaviors.library import parse_bid_terms
    from behaviors.params import ParamError

    try:
        return parse_bid_terms(text)
    except ParamError as exc:
        raise click.BadParameter(str(exc), param_hint="--metric") from exc


def run_experiment(
    *, experiment: str, duration_s: float, speedup: float, seed: int, meshcat: bool, out: Path,
    world_name: str, task_interval_s: float | None, kills: list[tuple[str, float]],
    restarts: list[tuple[str, float]], replay: bool, own: Mapping[str, Any] | None = None,
    pipelined: bool = True, robot_nice: int = 0, pin_cpus: bool = False,
    key: str | None = None, trails: int = 0, lasers: bool = False, record: bool = True,
    record_rate_hz: float = 2.0, metric_terms: tuple[str, ...] = (),
    extras: RunExtras | None = None, allocator: str = "murdoch",
    transport: str = "multicast", bind: str = "127.0.0.1",
    placements: tuple[tuple[str, tuple[str, ...]], ...] = (), refine: bool = False,
    robots_per_process: int | None = None, live_rate_hz: float = LIVE_RATE_HZ,
    plots: bool = True,
) -> int:
    """Run one experiment end to end; the exit code of `murdoch run`. `own`: the values of
    the experiment's own options by `Option.dest` (their defaults when not given)."""
    from experiments.plugin import RunOptions
    from experiments.run_extras import RunExtras
    from experiments.run_parts import RunSettings, assemble, check_run, finish, serve
    from experiments.task_source import PAPER_INTERVAL_S, team_task_interval_s

    settings = RunSettings(
        experiment=experiments()[experiment], world_name=world_name, speedup=speedup,
        meshcat=meshcat, out=out, kills=tuple(kills), restarts=tuple(restarts), replay=replay,
        pipelined=pipelined, robot_nice=robot_nice, pin_cpus=pin_cpus, key=key,
        trails=trails, lasers=lasers, record=record, record_rate_hz=record_rate_hz,
        metric_terms=metric_terms, extras=extras if extras is not None else RunExtras(),
        transport=transport, bind=bind, placements=placements, refine=refine,
        robots_per_process=robots_per_process, live_rate_hz=live_rate_hz, plots=plots)
    chosen = settings.experiment
    given = dict(own or {})
    unknown = sorted(set(given) - {o.dest for o in chosen.options})
    if unknown:
        raise click.UsageError(f"{chosen.name} has no option(s) {', '.join(unknown)}")
    options = RunOptions.of(chosen, duration_s, seed, allocator=allocator,
                            task_interval_s=(PAPER_INTERVAL_S if task_interval_s is None
                                             else task_interval_s), **given)
    spec, options = check_run(settings, options)
    if task_interval_s is None:  # the team's own rate (`team_task_interval_s`)
        options = dataclasses.replace(options, task_interval_s=team_task_interval_s(spec))
    parts = assemble(settings, options, spec)
    reason = serve(parts)
    return finish(parts, reason)


add_params(run, experiments())
