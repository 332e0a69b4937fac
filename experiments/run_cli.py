"""`murdoch run EXPERIMENT`: one command that runs an experiment end to end.

The runner process holds the simulation and the Player device server (its serving thread),
starts one `murdoch-robot` process per endpoint (robots joining MURDOCH over loopback
multicast on a port of their own, `behaviors.murdoch_link`), and is itself the user: it
introduces the experiment's tasks through a MURDOCH node, logs every auction message it
hears, and writes
the run directory through `experiments.recorder.RunRecorder`. Lockstep is used when running as
fast as possible (speedup 0), so a seeded run repeats.
"""

from __future__ import annotations

import logging
import os
import random
import re
import secrets
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from experiments.run_extras import RunExtras

log = logging.getLogger("murdoch.run")

EXPERIMENT_WORLDS = {"longterm": "longterm", "boxpush": "boxpush"}
KEY_ENV = "MURDOCH_TEAM_KEY"
DEFAULT_DURATION_S = 600.0
STALL_LIMIT_S = 180.0
EPOCH_ENV = "MURDOCH_RUN_EPOCH"
_DURATION_RE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([smh]?)\s*$")


def parse_duration_s(text: str) -> float:
    """'90m', '2h', '45s' or plain seconds."""
    m = _DURATION_RE.match(text)
    if not m:
        raise click.BadParameter(f"expected a duration such as 90m, 2h or 300s, got {text!r}")
    value, unit = float(m.group(1)), m.group(2) or "s"
    return value * {"s": 1.0, "m": 60.0, "h": 3600.0}[unit]


def parse_at(text: str) -> tuple[str, float]:
    """'p3@30m' -> ('p3', 1800.0)."""
    robot, sep, when = text.partition("@")
    if not sep or not robot:
        raise click.BadParameter(f"expected ROBOT@TIME such as p3@30m, got {text!r}")
    return robot, parse_duration_s(when)


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class RobotProcess:
    name: str
    port: int
    proc: subprocess.Popen[bytes] | None = None
    log_file: Any = None


def _start_robot(rp: RobotProcess, args: list[str], log_path: Path, nice: int = 0,
                 env: dict[str, str] | None = None) -> None:
    if rp.log_file is None:
        rp.log_file = log_path.open("ab")
    rp.proc = subprocess.Popen(args, stdout=rp.log_file, stderr=subprocess.STDOUT,
                               stdin=subprocess.DEVNULL, env=env)
    if nice > 0:
        # a lower priority than the simulator's serving thread, which every robot waits on
        try:
            os.setpriority(os.PRIO_PROCESS, rp.proc.pid, nice)
        except OSError as exc:  # the process may have gone already
            log.warning("could not lower the priority of robot %s: %s", rp.name, exc)


def _robot_command() -> list[str]:
    """The `murdoch-robot` entry point next to this interpreter (or its module)."""
    exe = Path(sys.executable).parent / "murdoch-robot"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "behaviors"]


def _place(sim: Any, name: str, pose: tuple[float, float, float],
           odometry: tuple[float, float, float] | None = None) -> None:
    """Teleport a robot (on the serving thread) and leave it standing still."""
    sim.set_velocity(name, 0.0, 0.0)
    sim.set_pose(name, *pose)
    if odometry is not None:
        sim.set_odometry(name, *odometry)


def _stop_robot(rp: RobotProcess, *, kill: bool = False, timeout_s: float = 5.0) -> None:
    if rp.proc is not None and rp.proc.poll() is None:
        if kill:
            rp.proc.kill()
        else:
            rp.proc.send_signal(signal.SIGCONT)  # a stopped (frozen) process could not end
            rp.proc.terminate()
        try:
            rp.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            rp.proc.kill()
            rp.proc.wait(timeout_s)
    if rp.log_file is not None:
        rp.log_file.close()
        rp.log_file = None


@click.command()
@click.argument("experiment", type=click.Choice(sorted(EXPERIMENT_WORLDS)))
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
@click.option("--world", default=None, help="World name or .toml (default: the experiment's).")
@click.option("--task-interval", type=float, default=240.0, show_default=True,
              help="Mean simulated seconds between new tasks.")
@click.option("--kill", "kills", multiple=True,
              help="Kill a robot process: ROBOT@TIME (ROBOT 'busy' = one holding a task).")
@click.option("--restart", "restarts", multiple=True,
              help="Start a killed robot again: ROBOT@TIME ('busy' = the last one killed so).")
@click.option("--switch-off", "switch_offs", multiple=True,
              help="boxpush: switch a pusher off (process stopped, robot moved out of the "
                   "way): ROBOT@TIME, e.g. p1@60s.")
@click.option("--switch-on", "switch_ons", multiple=True,
              help="boxpush: switch a pusher back on behind the other end of the box: "
                   "ROBOT@TIME.")
@click.option("--goal-radius", type=float, default=None,
              help="boxpush: the box has arrived when its centre is this close to the goal "
                   "marker (metres, default 2.5).")
@click.option("--goal-velocity", default=None,
              help="boxpush: the goal marker moves at VX,VY metres per second from the start "
                   "(e.g. 0,-0.01), stopping short of the walls.")
@click.option("--retarget", "retargets", multiple=True,
              help="boxpush: give the watch task another goal marker of the world at a time: "
                   "MARKER@TIME, e.g. goal2@60s.")
@click.option("--metric", "metric_terms", default="",
              help="Terms added to every robot's task metrics: distance (metres to where the "
                   "task is), specialist (fewer spare resources bid higher), comma-separated.")
@click.option("--no-replay", is_flag=True, help="Do not write replay.html.")
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
def run(experiment: str, sim_hours: float | None, until: str | None, speedup: float | None,
        seed: int,
        meshcat: bool, out: Path, world: str | None, task_interval: float,
        kills: tuple[str, ...], restarts: tuple[str, ...], switch_offs: tuple[str, ...],
        switch_ons: tuple[str, ...], goal_radius: float | None, goal_velocity: str | None,
        retargets: tuple[str, ...], metric_terms: str, no_replay: bool,
        pipelined: bool, robot_nice: int, key: str | None, pin_cpus: bool,
        record_rate: float, no_record: bool, trails: int, lasers: bool) -> None:
    """Run EXPERIMENT end to end and leave a run directory behind."""
    from experiments.run_checks import RunSetupError, check_out_dir, effective_speedup

    if sim_hours is not None and until is not None:
        raise click.UsageError("give --sim-hours or --until, not both")
    duration_s = (sim_hours * 3600.0 if sim_hours is not None
                  else parse_duration_s(until) if until is not None else DEFAULT_DURATION_S)
    try:
        check_out_dir(out)
        code = run_experiment(
            experiment=experiment, duration_s=duration_s,
            speedup=effective_speedup(speedup, meshcat), seed=seed,
            meshcat=meshcat, out=out, world_name=world or EXPERIMENT_WORLDS[experiment],
            task_interval_s=task_interval, kills=[parse_at(k) for k in kills],
            restarts=[parse_at(r) for r in restarts], replay=not no_replay,
            switch_offs=[parse_at(r) for r in switch_offs],
            switch_ons=[parse_at(r) for r in switch_ons], goal_radius_m=goal_radius,
            pipelined=pipelined, robot_nice=robot_nice, pin_cpus=pin_cpus, key=key,
            record=not no_record, record_rate_hz=record_rate, trails=trails, lasers=lasers,
            goal_plan=_goal_plan(goal_velocity, retargets),
            metric_terms=_metric_terms(metric_terms),
        )
    except RunSetupError as exc:
        click.echo(f"murdoch run: {exc}", err=True)
        sys.exit(exc.exit_code)
    sys.exit(code)


def _goal_plan(velocity: str | None, retargets: tuple[str, ...]) -> Any:
    from experiments import boxpush as bp

    try:
        v = bp.parse_velocity(velocity) if velocity else (0.0, 0.0)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--goal-velocity") from exc
    moves = tuple(sorted((t, m) for m, t in (parse_at(r) for r in retargets)))
    return bp.GoalPlan(v, moves)


def _metric_terms(text: str) -> tuple[str, ...]:
    from behaviors.library import parse_bid_terms
    from behaviors.params import ParamError

    try:
        return parse_bid_terms(text)
    except ParamError as exc:
        raise click.BadParameter(str(exc), param_hint="--metric") from exc


class RobotSupervisor:
    """The robot processes of a run: start, kill, notice deaths (`RobotProcesses`)."""

    def __init__(self, command: Callable[[str, int], list[str]], log_path: Callable[[str], Path],
                 env: dict[str, str], nice: int = 0) -> None:
        self._command = command
        self._log_path = log_path
        self._env = env
        self._nice = nice
        self.robots: dict[str, RobotProcess] = {}
        self._starts: dict[str, int] = {}
        self._lock = threading.Lock()

    def add(self, name: str, port: int) -> None:
        self.robots[name] = RobotProcess(name, port)

    def names(self) -> list[str]:
        return list(self.robots)

    def start(self, name: str) -> int:
        with self._lock:
            rp = self.robots[name]
            start = self._starts.get(name, 0)
            self._starts[name] = start + 1
            _start_robot(rp, self._command(name, start), self._log_path(name), self._nice,
                         self._env)
            assert rp.proc is not None
            return rp.proc.pid

    def kill(self, name: str) -> int | None:
        with self._lock:
            rp = self.robots[name]
            pid = rp.proc.pid if rp.proc is not None and rp.proc.poll() is None else None
            _stop_robot(rp, kill=True)
            rp.proc = None
            return pid

    def exited(self) -> list[tuple[str, int, int]]:
        out = []
        with self._lock:
            for name, rp in self.robots.items():
                proc = rp.proc
                if proc is not None and proc.poll() is not None:
                    out.append((name, proc.pid, int(proc.returncode)))
                    _stop_robot(rp)
                    rp.proc = None
        return out

    def pause(self, name: str, paused: bool) -> int | None:
        with self._lock:
            proc = self.robots[name].proc
            if proc is None or proc.poll() is not None:
                return None
            proc.send_signal(signal.SIGSTOP if paused else signal.SIGCONT)
            return proc.pid

    def alive_test(self, name: str) -> Callable[[], bool]:
        """A test of whether the robot's current process is still running."""
        rp = self.robots[name]

        def alive() -> bool:
            proc = rp.proc
            return proc is not None and proc.poll() is None

        return alive

    def pids(self) -> dict[str, int]:
        with self._lock:
            return {f"robot-{n}": rp.proc.pid for n, rp in self.robots.items()
                    if rp.proc is not None and rp.proc.poll() is None}

    def stop_all(self) -> None:
        with self._lock:
            for rp in self.robots.values():
                _stop_robot(rp)


def _robots_ready(server: Any, ports: dict[str, int]) -> bool:
    """Has every robot connected and asked for data? (A real-time run starts its clock then,
    so that slow-starting robot processes do not miss its beginning.)"""
    asked = {s.endpoint.name for s in list(server.core.sessions.values())
             if s.round_pending or s.last_round >= 0}
    return asked >= set(ports)


def _task_spec(planned: Any) -> Any:
    """The MURDOCH announcement of one planned task of the task source."""
    from behaviors.library import TASKS
    from murdoch.auction.timing import USER_TASK

    kind = planned.kind
    return USER_TASK.task(kind, TASKS[kind].subjects, planned.params,
                          duration_s=float(planned.params.get("duration_s", 0.0)),
                          timeout_s=float(planned.params["duration_s"]) + 600.0)


def run_experiment(
    *, experiment: str, duration_s: float, speedup: float, seed: int, meshcat: bool, out: Path,
    world_name: str, task_interval_s: float, kills: list[tuple[str, float]],
    restarts: list[tuple[str, float]], replay: bool,
    switch_offs: list[tuple[str, float]] | None = None,
    switch_ons: list[tuple[str, float]] | None = None, goal_radius_m: float | None = None,
    pipelined: bool = True, robot_nice: int = 0, pin_cpus: bool = False,
    key: str | None = None, trails: int = 0, lasers: bool = False, record: bool = True,
    record_rate_hz: float = 2.0, goal_plan: Any = None, metric_terms: tuple[str, ...] = (),
    extras: RunExtras | None = None,
) -> int:
    from experiments import boxpush as bp
    from experiments import events as ev
    from experiments.end_report import end_of_run_lines
    from experiments.observe import JsonlTail
    from experiments.recorder import RunRecorder
    from experiments.run_checks import (
        RunSetupError,
        check_schedule,
        describe_os_error,
        load_run_world,
    )
    from experiments.run_extras import RunExtras
    from experiments.run_loop import Fault, RunLoop
    from experiments.summary import terminal_state_problems
    from experiments.task_source import boxpush_task, longterm_tasks
    from murdoch.auth import TeamKey
    from murdoch.lossy import ENV as LOSS_ENV
    from murdoch.lossy import LossSpec, LossyReceiver
    from murdoch.multicast import MulticastConfig, MulticastTransport
    from murdoch.node import Node
    from murdoch.transport import TickConfig
    from murdoch.user_agent import RandomizedBackoff
    from player_server.drivers.team_clock import TeamClock, TeamClockDriver
    from player_server.server.affinity import allowed_cpus, pin_current_thread, plan_split
    from player_server.server.assembly import world_endpoints
    from player_server.server.core import CoreConfig
    from player_server.server.runner import PlayerServer
    from player_server.sim import Simulation

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    extras = extras if extras is not None else RunExtras()
    spec = load_run_world(world_name)
    lockstep = speedup == 0
    switch_offs, switch_ons = list(switch_offs or ()), list(switch_ons or ())
    names = [r.name for r in spec.robots]
    try:
        switch_offs = [(bp.resolve_robot(r, names), t) for r, t in switch_offs]
        switch_ons = [(bp.resolve_robot(r, names), t) for r, t in switch_ons]
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from exc
    goal_plan = goal_plan or bp.GoalPlan()
    if (switch_offs or switch_ons or goal_plan != bp.GoalPlan()) and experiment != "boxpush":
        raise click.UsageError("--switch-off/--switch-on/--goal-velocity/--retarget are for "
                               "the boxpush experiment")
    for _, marker in goal_plan.retargets:
        try:
            bp.marker_goal(spec, marker)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--retarget") from exc
    if not any(r.mobile for r in spec.robots):
        raise RunSetupError(f"world {spec.source}: no mobile robot can take part in "
                            f"{experiment} (every robot lacks position2d)")
    check_schedule(robots=names, duration_s=duration_s, kills=kills, restarts=restarts,
                   switch_offs=switch_offs, switch_ons=switch_ons, world=world_name)
    goal_watch = actions = None
    if experiment == "boxpush":
        goal_watch = bp.GoalWatch(bp.box_goal(spec), goal_radius_m or bp.GOAL_RADIUS_M,
                                 tuple(r.name for r in spec.robots if r.mobile))
        actions = bp.SimActions()
    mcast_port = free_udp_port()
    own_cpus = allowed_cpus()
    split = plan_split(own_cpus) if pin_cpus and own_cpus is not None else None
    # a team of its own: a fresh key (and epoch) per run unless one is given; robots get
    # them through the environment, never on the command line
    secret = key or os.environ.get(KEY_ENV) or secrets.token_hex(16)
    epoch = secrets.token_hex(4)
    config = {
        "experiment": experiment, "seed": seed, "world": world_name,
        "duration_s": duration_s, "speedup": speedup, "lockstep": lockstep,
        "task_interval_s": task_interval_s,
        "pipelined": lockstep and pipelined, "robot_nice": robot_nice,
        "cpu_affinity": split.as_dict() if split is not None else None,
        "kills": [f"{r}@{t:g}s" for r, t in kills],
        "restarts": [f"{r}@{t:g}s" for r, t in restarts],
        "team_key": "given" if key or os.environ.get(KEY_ENV) else "fresh",
    }
    if goal_watch is not None:
        config.update({
            "switch_offs": [f"{r}@{t:g}s" for r, t in switch_offs],
            "switch_ons": [f"{r}@{t:g}s" for r, t in switch_ons],
            "goal_radius_m": goal_watch.radius_m,
            "goal_velocity_mps": list(goal_plan.velocity_mps),
            "retargets": [f"{m}@{t:g}s" for t, m in goal_plan.retargets],
        })
    if metric_terms:
        config["metric_terms"] = list(metric_terms)
    config.update(extras.config)
    try:
        rec = RunRecorder(out, experiment, config, world=spec, started=datetime.now(),
                          wall_clock=time.monotonic, stream=sys.stdout, meshcat=meshcat,
                          record=record, record_rate_hz=record_rate_hz,
                          live_trail_points=trails, live_lasers=lasers)
    except OSError as exc:
        raise RunSetupError(describe_os_error(
            exc, f"--out {out}: cannot create the run directory")) from exc
    click.echo(f"run directory: {rec.run.root}")
    if extras.on_run_dir is not None:
        extras.on_run_dir(rec.run.root)
    sim = Simulation(spec, seed=seed)
    endpoints = world_endpoints(spec, sim, 0)
    team_clock = TeamClock() if lockstep else None
    if team_clock is not None:
        for endpoint in endpoints:
            drv = TeamClockDriver(team_clock, endpoint.name)
            endpoint.drivers[(drv.interf, drv.index)] = drv
    if split is not None:
        # this thread, and so every thread and robot process started from now on, keeps off
        # the serving thread's CPU
        pin_current_thread(split.others)
    samplers: tuple[tuple[float, Any], ...] = ()
    if goal_watch is not None and actions is not None:
        samplers = ((0.5, goal_watch.sample), (0.0, actions.apply))
    server = PlayerServer(
        rec.observe(sim, samplers=samplers), endpoints, interval_s=sim.interval_s,
        clock=time.monotonic, speedup=speedup, quit_time_s=0.0,
        config=CoreConfig(lockstep=lockstep, lockstep_clients=1,
                          lockstep_timeout_s=0.0 if lockstep else 5.0, pipelined=pipelined),
        cpus=split.serving if split is not None else None,
    )
    env = {**os.environ, KEY_ENV: secret, EPOCH_ENV: epoch}
    bus_loss = None
    if extras.bus_loss is not None and not lockstep:
        # every receiver of the bus, the runner's node included, drops and delays
        env[LOSS_ENV] = extras.bus_loss
        bus_loss = LossyReceiver(LossSpec.parse(extras.bus_loss), "user", time.monotonic)
    tails: dict[str, tuple[JsonlTail, JsonlTail]] = {}
    ports: dict[str, int] = {}

    def robot_args(name: str, start: int) -> list[str]:
        args = [*_robot_command(), "-p", str(ports[name]),
                "--name", name, "--world", str(spec.source), "--mcast-port",
                str(mcast_port), "--seed", str(seed), "--instance", str(start),
                "--events", str(rec.run.logs / f"{name}.events.jsonl"),
                "--auction-log", str(rec.run.logs / f"{name}.auction.jsonl")]
        if metric_terms:
            args += ["--metric", ",".join(metric_terms)]
        if not lockstep:
            return args
        # in lockstep a robot waits for the slowest of the team (one starting up on a
        # loaded machine, say): the runner's own stall limit ends a run that truly hangs
        return [*args, "--lockstep-bus", "--request-timeout", "120",
                "--read-timeout", str(int(STALL_LIMIT_S * 4))]

    supervisor = RobotSupervisor(robot_args, lambda n: rec.run.log_file(f"robot-{n}"), env,
                                 robot_nice)
    interval = float(sim.interval_s)

    def user_tick() -> int:
        return round(float(sim.time_s) / interval)

    sim_now = lambda: float(sim.time_s)  # noqa: E731 - a float read across threads
    ticks = TickConfig(user_tick, epoch=epoch, ordered=lockstep, late_joiner=False,
                       stale_after_ticks=0 if lockstep else 100, require_tick=True)
    transport = MulticastTransport("user", sim_now, MulticastConfig(port=mcast_port),
                                   key=TeamKey(secret), instance="0", ticks=ticks,
                                   loss=bus_loss)
    loop_ref: list[RunLoop] = []
    node = Node(transport, sim_now, agent_id="user",
                observer=lambda e: loop_ref[0].on_auction_event(e.to_dict()),
                backoff=RandomizedBackoff(random.Random(seed), base_s=5.0, cap_s=60.0))
    if experiment == "boxpush":
        planned: Any = iter([boxpush_task(spec, duration_s), None])
    else:
        planned = longterm_tasks(spec, random.Random(seed + 1), mean_interval_s=task_interval_s)
    faults = ([Fault(t, "kill", r) for r, t in kills]
              + [Fault(t, "restart", r) for r, t in restarts]
              + [Fault(t, "switch-off", r) for r, t in switch_offs]
              + [Fault(t, "switch-on", r) for r, t in switch_ons] + list(extras.faults))

    def hold_clock(name: str, hold: bool) -> None:
        # on the serving thread: a stopped robot's session no longer holds the lockstep
        for s in list(server.core.sessions.values()):
            if s.endpoint.name == name:
                s.lockstep_override = None if hold else False
    loop = RunLoop(
        rec=rec, sim=sim, node=node, transport=transport, processes=supervisor, tails=tails,
        planned=planned, task_subjects=lambda k: (), task_spec=_task_spec,
        duration_s=duration_s, faults=faults,
        expect=((lambda n: server.core.expect(n, supervisor.alive_test(n))) if lockstep
                else None),
        team_clock=team_clock,
        wait_clock=time.monotonic, request_stop=server.request_stop,
        boxpush=(goal_watch, actions) if goal_watch is not None else None,
        mobile=frozenset(r.name for r in spec.robots if r.mobile), spec=spec, place=_place,
        goal_plan=goal_plan,
        hold_clock=hold_clock,
        burst=(longterm_tasks(spec, random.Random(extras.burst_seed),
                              mean_interval_s=task_interval_s)
               if extras.burst_seed is not None else None),
    )
    loop_ref.append(loop)
    monitor = transport.subscribe(None, loop.on_message)
    server.on_round = loop.on_round
    stop_requested = [False]

    def on_signal(signum: int, frame: object) -> None:
        stop_requested[0] = True
        server.request_stop()

    old_int = signal.signal(signal.SIGINT, on_signal)
    old_term = signal.signal(signal.SIGTERM, on_signal)
    reason = "completed"
    try:
        rec.start()
        if not lockstep:
            sim.set_paused(True)  # the clock starts once every robot is ready (below)
        server.start()
        ports.update(server.ports)
        for ep in endpoints:
            supervisor.add(ep.name, ports[ep.name])
            tails[ep.name] = (JsonlTail(rec.run.logs / f"{ep.name}.events.jsonl"),
                              JsonlTail(rec.run.logs / f"{ep.name}.auction.jsonl"))
        loop.tails = dict(sorted(tails.items()))
        for ep in endpoints:
            rec.note_process(0.0, "started", ep.name, supervisor.start(ep.name))
            if lockstep:
                server.core.expect(ep.name, supervisor.alive_test(ep.name))
        next_memory_wall = time.monotonic() + 2.0
        last_progress = (sim_now(), time.monotonic())
        waiting_for_robots = not lockstep
        while not server.finished.wait(0.25):
            rec.tick()
            wall = time.monotonic()
            if waiting_for_robots and _robots_ready(server, ports):
                waiting_for_robots = False
                sim.set_paused(False)
            if wall >= next_memory_wall:
                next_memory_wall = wall + extras.memory_every_s
                rec.sample_processes(sim_now(), {"runner": os.getpid(), **supervisor.pids()})
            if sim_now() != last_progress[0]:
                last_progress = (sim_now(), wall)
            elif lockstep and wall - last_progress[1] > STALL_LIMIT_S:
                # nothing decides on wall time in a lockstep run, but a run whose robots
                # stopped answering must end rather than hang
                loop.state.error = RuntimeError(
                    f"the simulation has not advanced for {STALL_LIMIT_S:.0f} s of wall time "
                    f"at {sim_now():.1f} s simulated; waiting for "
                    f"{sorted(server.core.expected) or 'robot processes'} (see "
                    f"{rec.run.logs})")
                server.request_stop()
        rec.sample_processes(sim_now(), {"runner": os.getpid(), **supervisor.pids()})
        if stop_requested[0]:
            reason = "interrupted"
        elif loop.state.error is not None:
            reason = "error"
            click.echo(f"error: {loop.state.error}", err=True)
        elif server.error is not None:
            reason = "server-error"
        else:
            reason = loop.state.end_reason or "completed"
        # an end not decided at a tick boundary (interrupted, failed): close what is open
        loop.close_open_tasks(loop.state.last_t)
        monitor.close()
    except OSError as exc:  # e.g. the disk filled up under the run directory
        click.echo(f"murdoch run: {describe_os_error(exc, f'writing {rec.run.root}')}",
                   err=True)
        reason = "error"
    except Exception:
        log.exception("the run failed")
        reason = "error"
    finally:
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, old_term)
        supervisor.stop_all()
        for events_tail, auctions_tail in tails.values():
            events_tail.close()
            auctions_tail.close()
        node.close()
        transport.close()
        try:
            server.stop()
        except RuntimeError as exc:
            log.error("server: %s", exc)
            reason = "server-error"
        sim.close()
        if split is not None and own_cpus is not None:
            pin_current_thread(own_cpus)  # the report may use every CPU again
    keep_viewer = meshcat and reason == "completed"
    report = rec.finish(reason, replay=replay, end_t=loop.state.last_t,
                        keep_viewer=keep_viewer,
                        extra=({"bus_loss_runner": {"dropped": bus_loss.dropped,
                                                    "delayed": bus_loss.delayed}}
                               if bus_loss is not None else None))
    problems = terminal_state_problems(ev.read_events(rec.run.events))
    s = report.summary
    if loop.state.goal_outcome == "reached" and goal_watch is not None:
        click.echo(f"goal reached at {goal_watch.reached_at_s:.1f} s simulated: "
                   f"box {goal_watch.distance_m:.2f} m from the goal")
    for line in end_of_run_lines(experiment=experiment, reason=reason, run_root=rec.run.root,
                                 summary=s, plots=report.plots, replay=report.replay,
                                 problems=report.problems):
        click.echo(line)
    click.echo(f"events sha256 {s['events_sha256']} (a lockstep run with the same world, seed "
               f"and options writes the same events.jsonl)" if lockstep
               else f"events sha256 {s['events_sha256']}")
    if keep_viewer:
        rec.hold_viewer(signal.pause)
    if any(problems.values()):
        click.echo(f"invariant broken: {problems}", err=True)
        return 3
    goal = s.get("goal")
    if goal is not None and goal.get("unachievable"):
        click.echo(f"error: the box cannot be pushed to the goal: "
                   f"{goal.get('unachievable_reason')}", err=True)
        return 4
    return 0 if reason == "completed" else 1
