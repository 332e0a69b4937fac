"""The pieces of one run and how they are put together, served and reported on.

`experiments.run_cli.run_experiment` is `check_run`, `assemble`, `serve` and `finish` in
turn. `assemble` builds, from the experiment's plug-in and the run's settings: the
recorder (run directory), the simulation and its Player server, the team clock (lockstep),
the robot processes (described as data, `experiments.supervisor.ProcessSpec`, and listed in
config.json), the user's MURDOCH node and the runner's loop with the experiment's referee.
`serve` runs the main thread's wall-clock loop until the serving thread ends the run;
`finish` writes the report and says how the run went.
"""

from __future__ import annotations

import logging
import os
import random
import secrets
import signal
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from experiments.plugin import Experiment, Fault, Referee, RunOptions, labels
from experiments.run_checks import LIVE_RATE_HZ
from experiments.supervisor import BusPlace, RobotSupervisor, robot_process

if TYPE_CHECKING:
    from experiments.observe import JsonlTail
    from experiments.recorder import RunRecorder
    from experiments.robot_hosts import HostSupervisor
    from experiments.run_extras import RunExtras
    from experiments.run_loop import RunLoop
    from murdoch.lossy import LossyReceiver
    from murdoch.member import TeamMember
    from murdoch.multicast import MulticastTransport
    from murdoch.zenoh_transport import ZenohTransport
    from player_server.server.affinity import CpuSplit
    from player_server.server.runner import PlayerServer
    from player_server.sim import Simulation
    from worlds import WorldSpec

log = logging.getLogger("murdoch.run")

KEY_ENV = "MURDOCH_TEAM_KEY"
EPOCH_ENV = "MURDOCH_RUN_EPOCH"
STALL_LIMIT_S = 180.0


@dataclass(frozen=True)
class RunSettings:
    """How to run (the same for every experiment): `murdoch run`'s options."""

    experiment: Experiment
    world_name: str
    speedup: float
    meshcat: bool
    out: Path
    kills: tuple[tuple[str, float], ...]
    restarts: tuple[tuple[str, float], ...]
    replay: bool
    pipelined: bool
    robot_nice: int
    pin_cpus: bool
    key: str | None
    trails: int
    lasers: bool
    record: bool
    record_rate_hz: float
    metric_terms: tuple[str, ...]
    extras: RunExtras
    transport: str = "multicast"
    """The team bus: loopback UDP multicast, or Zenoh with the runner's node as the hub."""
    bind: str = "127.0.0.1"
    """Where the Player server (and a Zenoh hub) listen; another address only when asked."""
    placements: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(robot, launch prefix): robot processes started elsewhere (`ProcessSpec.launch`)."""
    refine: bool = False
    """The robots' consensus agents run the improvement phase (`murdoch run --refine`)."""
    robots_per_process: int | None = None
    """1: a `murdoch-robot` process per robot; above 1: robots run that many to a host
    process, each in a thread (`experiments.robot_hosts`); None: chosen from the team's size
    (`experiments.robot_hosts.robots_per_process`)."""
    live_rate_hz: float = LIVE_RATE_HZ
    """Frames per wall-clock second sent to the live view (`murdoch run --live-rate`)."""
    plots: bool = True
    """Draw plots/*.png when the run ends (`murdoch run --no-plots` leaves them to `murdoch
    report`)."""

    @property
    def lockstep(self) -> bool:
        return self.speedup == 0


@dataclass
class RunParts:
    """Everything `assemble` built, for `serve` and `finish`."""

    settings: RunSettings
    options: RunOptions
    rec: RunRecorder
    sim: Simulation
    server: PlayerServer
    supervisor: RobotSupervisor | HostSupervisor
    transport: MulticastTransport | ZenohTransport
    node: TeamMember
    loop: RunLoop
    referee: Referee
    split: CpuSplit | None
    own_cpus: frozenset[int] | None
    bus_loss: LossyReceiver | None
    endpoint_names: list[str]
    tails: dict[str, tuple[JsonlTail, JsonlTail]] = field(default_factory=dict)
    ports: dict[str, int] = field(default_factory=dict)


def check_run(settings: RunSettings, options: RunOptions) -> tuple[WorldSpec, RunOptions]:
    """The world and the options checked against it (clear errors, nothing started)."""
    from experiments.run_checks import RunSetupError, check_schedule, load_run_world
    from experiments.run_tasks import check_supports

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    spec = load_run_world(settings.world_name)
    check_supports(settings.experiment, options.allocator)
    options = settings.experiment.check(spec, options)
    if not any(r.mobile for r in spec.robots):
        raise RunSetupError(f"world {spec.source}: no mobile robot can take part in "
                            f"{settings.experiment.name} (every robot lacks position2d)")
    _check_placement(settings, {r.name for r in spec.robots})
    own = settings.experiment.faults(options)
    check_schedule(robots=[r.name for r in spec.robots], duration_s=options.duration_s,
                   kills=list(settings.kills), restarts=list(settings.restarts),
                   switch_offs=[(f.robot, f.t_s) for f in own if f.action == "switch-off"],
                   switch_ons=[(f.robot, f.t_s) for f in own if f.action == "switch-on"],
                   world=settings.world_name)
    return spec, options


def _check_placement(settings: RunSettings, robots: set[str]) -> None:
    """Transport, address and placements that fit together (clear errors, nothing started)."""
    import ipaddress

    from experiments.run_checks import RunSetupError

    try:
        bind = ipaddress.IPv4Address(settings.bind)
    except ValueError:
        raise RunSetupError(f"--bind {settings.bind!r}: expected an IPv4 address") from None
    if bind.is_unspecified or bind.is_multicast:
        raise RunSetupError(f"--bind {settings.bind}: expected one address of this host (the "
                            "robots are told it), not a wildcard or a group")
    for name, _ in settings.placements:
        if name not in robots:
            raise RunSetupError(f"--place {name}=...: the world has no robot {name!r} "
                                f"(robots: {', '.join(sorted(robots))})")
    if settings.transport != "zenoh" and (settings.placements or settings.bind != "127.0.0.1"):
        raise RunSetupError("robots on other hosts (--place, --bind) need --transport zenoh: "
                            "the multicast bus stays on this host's loopback")
    if settings.transport == "zenoh" and settings.extras.bus_loss is not None:
        raise RunSetupError("--bus-loss is a layer of the multicast receiver; it cannot be "
                            "combined with --transport zenoh")
    per_process = settings.robots_per_process
    if per_process is None:
        return  # auto: one each wherever one robot's own process is needed
    if not isinstance(per_process, int) or isinstance(per_process, bool) or per_process < 1:
        raise RunSetupError(f"--robots-per-process {per_process!r}: expected a whole number, "
                            "at least 1 (or auto)")
    if per_process > 1 and settings.placements:
        raise RunSetupError("--place starts one robot's own process elsewhere; it cannot be "
                            "combined with --robots-per-process above 1")
    paused = _pausing_actions(settings)
    if per_process > 1 and paused:
        raise RunSetupError(f"{' and '.join(paused)} pause one robot's process; a robot sharing "
                            "its process with others (--robots-per-process above 1) cannot be "
                            "paused alone")


def run_config(settings: RunSettings, options: RunOptions,
               split: CpuSplit | None) -> dict[str, Any]:
    """config.json's entries (the processes are added once they are known)."""
    config: dict[str, Any] = {
        "experiment": settings.experiment.name, "seed": options.seed,
        "world": settings.world_name, "duration_s": options.duration_s,
        "speedup": settings.speedup, "lockstep": settings.lockstep,
        "task_interval_s": options.task_interval_s,
        "pipelined": settings.lockstep and settings.pipelined,
        "robot_nice": settings.robot_nice,
        "cpu_affinity": split.as_dict() if split is not None else None,
        "kills": labels(settings.kills), "restarts": labels(settings.restarts),
        "team_key": "given" if settings.key or os.environ.get(KEY_ENV) else "fresh",
        "allocator": options.allocator, "refine": settings.refine,
        "transport": settings.transport, "bind": settings.bind,
    }
    config.update(settings.experiment.config(options))
    if settings.metric_terms:
        config["metric_terms"] = list(settings.metric_terms)
    config.update(settings.extras.config)
    return config


def assemble(settings: RunSettings, options: RunOptions, spec: WorldSpec) -> RunParts:
    """Build every piece of the run (nothing runs yet)."""
    from experiments.ports import free_tcp_port, free_udp_port
    from experiments.recorder import RunRecorder
    from experiments.run_checks import RunSetupError, describe_os_error
    from player_server.drivers.team_clock import TeamClock, TeamClockDriver
    from player_server.server.affinity import allowed_cpus, pin_current_thread, plan_split
    from player_server.server.assembly import world_endpoints
    from player_server.server.core import CoreConfig
    from player_server.server.runner import PlayerServer
    from player_server.sim import Simulation

    lockstep = settings.lockstep
    referee = settings.experiment.referee(spec, options)
    mcast_port = free_udp_port()
    zenoh_endpoint = (f"tcp/{settings.bind}:{free_tcp_port(settings.bind)}"
                      if settings.transport == "zenoh" else "")
    own_cpus = allowed_cpus()
    split = plan_split(own_cpus) if settings.pin_cpus and own_cpus is not None else None
    # a team of its own: a fresh key (and epoch) per run unless one is given; robots get
    # them through the environment, never on the command line
    secret = settings.key or os.environ.get(KEY_ENV) or secrets.token_hex(16)
    epoch = secrets.token_hex(4)
    try:
        rec = RunRecorder(settings.out, settings.experiment.name,
                          run_config(settings, options, split), world=spec,
                          started=datetime.now(), wall_clock=time.monotonic, stream=sys.stdout,
                          meshcat=settings.meshcat, record=settings.record,
                          record_rate_hz=settings.record_rate_hz,
                          live_rate_hz=settings.live_rate_hz,
                          live_trail_points=settings.trails, live_lasers=settings.lasers)
    except OSError as exc:
        raise RunSetupError(describe_os_error(
            exc, f"--out {settings.out}: cannot create the run directory")) from exc
    click.echo(f"run directory: {rec.run.root}")
    if settings.extras.on_run_dir is not None:
        settings.extras.on_run_dir(rec.run.root)
    sim = Simulation(spec, seed=options.seed)
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
    server = PlayerServer(
        rec.observe(sim, samplers=referee.samplers), endpoints, interval_s=sim.interval_s,
        clock=time.monotonic, speedup=settings.speedup, quit_time_s=0.0, host=settings.bind,
        config=CoreConfig(lockstep=lockstep, lockstep_clients=1,
                          lockstep_timeout_s=0.0 if lockstep else 5.0,
                          pipelined=settings.pipelined, step_without_participants=True),
        cpus=split.serving if split is not None else None,
    )
    env = {**os.environ, KEY_ENV: secret, EPOCH_ENV: epoch}
    bus = BusPlace(server_host=settings.bind, mcast_port=mcast_port,
                   zenoh_endpoint=zenoh_endpoint)
    launches = dict(settings.placements)
    specs = {ep.name: robot_process(
        ep.name, world=str(spec.source), bus=bus, seed=options.seed,
        logs=rec.run.logs, metric_terms=settings.metric_terms, lockstep=lockstep,
        read_timeout_s=STALL_LIMIT_S * 4, allocator=options.allocator,
        launch=launches.get(ep.name, ()), refine=settings.refine) for ep in endpoints}
    rec.config["processes"] = [p.as_dict() for p in specs.values()]
    bus_loss = _bus_loss(settings, env)
    supervisor = _supervisor(settings, specs, rec, env)
    transport, node, loop = _user(settings, options, spec, sim, server, supervisor, rec,
                                  referee, team_clock, bus, secret, epoch, bus_loss)
    return RunParts(settings, options, rec, sim, server, supervisor, transport, node, loop,
                    referee, split, own_cpus, bus_loss, [ep.name for ep in endpoints])


def _pausing_actions(settings: RunSettings) -> list[str]:
    """The fault schedule's actions that pause one robot's process (freeze, thaw)."""
    return sorted({f.action for f in settings.extras.faults if f.action in ("freeze", "thaw")})


def _supervisor(settings: RunSettings, specs: dict[str, Any], rec: RunRecorder,
                env: dict[str, str]) -> RobotSupervisor | HostSupervisor:
    """A process per robot, or (--robots-per-process above 1) robots grouped into hosts in
    the world's order (their layout goes into config.json)."""
    from experiments.robot_hosts import HostSupervisor, group_robots, robots_per_process
    from player_server.server.affinity import allowed_cpus

    per_process = robots_per_process(settings.robots_per_process, len(specs),
                                     placed=bool(settings.placements),
                                     pausing=bool(_pausing_actions(settings)),
                                     cpus=len(allowed_cpus() or ()) or os.cpu_count() or 1)
    if per_process == 1:
        return RobotSupervisor(specs, lambda n: rec.run.log_file(f"robot-{n}"), env,
                               settings.robot_nice)
    hosts = HostSupervisor(specs, group_robots(list(specs), per_process),
                           rec.run.log_file, env, settings.robot_nice)
    rec.config["robots_per_process"] = per_process
    rec.config["robot_hosts"] = hosts.layout()
    return hosts


def _bus_loss(settings: RunSettings, env: dict[str, str]) -> LossyReceiver | None:
    from murdoch.lossy import ENV as LOSS_ENV
    from murdoch.lossy import LossSpec, LossyReceiver

    loss = settings.extras.bus_loss
    if loss is None or settings.lockstep:
        return None
    # every receiver of the bus, the runner's node included, drops and delays
    env[LOSS_ENV] = loss
    return LossyReceiver(LossSpec.parse(loss), "user", time.monotonic)


def _user(settings: RunSettings, options: RunOptions, spec: WorldSpec, sim: Simulation,
          server: PlayerServer, supervisor: RobotSupervisor | HostSupervisor, rec: RunRecorder,
          referee: Referee, team_clock: Any, bus: BusPlace, secret: str, epoch: str,
          bus_loss: LossyReceiver | None,
          ) -> tuple[MulticastTransport | ZenohTransport, TeamMember, RunLoop]:
    """The user's side: its transport on the team's bus (the Zenoh hub when the bus is
    Zenoh), its allocator's member (a MURDOCH node by default) and the loop."""
    from experiments.run_checks import RunSetupError
    from experiments.run_loop import RunLoop
    from experiments.run_tasks import task_place, task_spec
    from experiments.task_source import longterm_tasks
    from murdoch.allocators import UserHooks, allocator
    from murdoch.auth import TeamKey
    from murdoch.endpoint import EndpointOptions
    from murdoch.multicast import MulticastConfig
    from murdoch.transport import TickConfig
    from murdoch.transport_choice import TransportChoice, open_transport
    from murdoch.user_agent import RandomizedBackoff
    from murdoch.zenoh_transport import ZenohConfig, ZenohUnavailable

    lockstep, extras = settings.lockstep, settings.extras
    interval = float(sim.interval_s)

    def user_tick() -> int:
        return round(float(sim.time_s) / interval)

    sim_now = lambda: float(sim.time_s)  # noqa: E731 - a float read across threads
    ticks = TickConfig(user_tick, epoch=epoch, ordered=lockstep, late_joiner=False,
                       stale_after_ticks=0 if lockstep else 100, require_tick=True)
    team = allocator(options.allocator)
    if bus.zenoh_endpoint:
        choice = TransportChoice("zenoh", zenoh=ZenohConfig(
            endpoint=bus.zenoh_endpoint, hub=True, allow_remote=settings.bind != "127.0.0.1"))
    else:
        choice = TransportChoice("multicast", multicast=MulticastConfig(port=bus.mcast_port))
    try:
        transport = open_transport(choice, "user", sim_now,
                                   EndpointOptions(codec=team.codec, key=TeamKey(secret),
                                                   instance="0", ticks=ticks),
                                   loss=bus_loss)
    except (ZenohUnavailable, OSError) as exc:
        raise RunSetupError(f"cannot open the team's bus ({choice.describe()}): {exc}") from exc
    loop_ref: list[RunLoop] = []
    node = team.user(transport, sim_now, UserHooks(
        "user", observer=lambda e: loop_ref[0].on_auction_event(e.to_dict()),
        backoff=RandomizedBackoff(random.Random(options.seed), base_s=5.0, cap_s=60.0),
        locate=task_place(spec, sim)))
    faults = ([Fault(t, "kill", r) for r, t in settings.kills]
              + [Fault(t, "restart", r) for r, t in settings.restarts]
              + settings.experiment.faults(options) + list(extras.faults))

    def hold_clock(name: str, hold: bool) -> None:
        # on the serving thread: a stopped robot's session no longer holds the lockstep
        for s in list(server.core.sessions.values()):
            if s.endpoint.name == name:
                s.lockstep_override = None if hold else False

    loop = RunLoop(
        rec=rec, sim=sim, node=node, transport=transport, processes=supervisor, tails={},
        planned=settings.experiment.tasks(spec, options), task_subjects=lambda k: (),
        task_spec=task_spec, duration_s=options.duration_s, faults=faults,
        expect=((lambda n: server.core.expect(n, supervisor.alive_test(n))) if lockstep
                else None),
        team_clock=team_clock, wait_clock=time.monotonic, request_stop=server.request_stop,
        referee=referee, mobile=frozenset(r.name for r in spec.robots if r.mobile),
        hold_clock=hold_clock, whole_groups=team.group_tasks,
        burst=(longterm_tasks(spec, random.Random(extras.burst_seed),
                              mean_interval_s=options.task_interval_s)
               if extras.burst_seed is not None else None),
    )
    loop_ref.append(loop)
    return transport, node, loop


def _robots_ready(server: Any, ports: dict[str, int]) -> bool:
    """Has every robot connected and asked for data? (A real-time run starts its clock then,
    so that slow-starting robot processes do not miss its beginning.)"""
    asked = {s.endpoint.name for s in list(server.core.sessions.values())
             if s.round_pending or s.last_round >= 0}
    return asked >= set(ports)


def serve(parts: RunParts) -> str:
    """Run until the serving thread ends the run (or a signal, or a stall); the end reason.
    Everything is stopped and closed when this returns."""
    from experiments.run_checks import describe_os_error

    loop, server = parts.loop, parts.server
    monitor = parts.transport.subscribe(None, loop.on_message)
    server.on_round = loop.on_round
    stop_requested = [False]

    def on_signal(signum: int, frame: object) -> None:
        stop_requested[0] = True
        server.request_stop()

    old_int = signal.signal(signal.SIGINT, on_signal)
    old_term = signal.signal(signal.SIGTERM, on_signal)
    reason = "completed"
    try:
        _start(parts)
        _watch(parts)
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
        click.echo(f"murdoch run: {describe_os_error(exc, f'writing {parts.rec.run.root}')}",
                   err=True)
        reason = "error"
    except Exception:
        log.exception("the run failed")
        reason = "error"
    finally:
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, old_term)
        reason = _teardown(parts, reason)
    return reason


def _start(parts: RunParts) -> None:
    """Start the recording, the server and every robot process."""
    from experiments.log_writes import FolderWrites
    from experiments.observe import JsonlTail

    rec, server, supervisor = parts.rec, parts.server, parts.supervisor
    lockstep = parts.settings.lockstep
    rec.start()
    if not lockstep:
        parts.sim.set_paused(True)  # the clock starts once every robot is ready (_watch)
    server.start()
    parts.ports.update(server.ports)
    for name in parts.endpoint_names:
        supervisor.add(name, parts.ports[name])
        parts.tails[name] = (JsonlTail(rec.run.logs / f"{name}.events.jsonl"),
                             JsonlTail(rec.run.logs / f"{name}.auction.jsonl"))
    parts.loop.tails = dict(sorted(parts.tails.items()))
    parts.loop.log_writes = FolderWrites(rec.run.logs)  # before any robot can write
    for name in parts.endpoint_names:
        rec.note_process(0.0, "started", name, supervisor.start(name))
        if lockstep:
            server.core.expect(name, supervisor.alive_test(name))


def _watch(parts: RunParts) -> None:
    """The main thread's wall-clock work until the run ends: progress, memory samples,
    starting a real-time run's clock, and ending a lockstep run that stalls."""
    rec, server, loop, supervisor = parts.rec, parts.server, parts.loop, parts.supervisor
    lockstep = parts.settings.lockstep
    sim_now = lambda: float(parts.sim.time_s)  # noqa: E731
    next_memory_wall = time.monotonic() + 2.0
    last_progress = (sim_now(), time.monotonic())
    waiting_for_robots = not lockstep
    # a fast run samples memory more often than the progress cadence when asked to
    period = min(0.25, parts.settings.extras.memory_every_s)
    while not server.finished.wait(period):
        rec.tick()
        wall = time.monotonic()
        if waiting_for_robots and _robots_ready(server, parts.ports):
            waiting_for_robots = False
            parts.sim.set_paused(False)
        if wall >= next_memory_wall:
            next_memory_wall = wall + parts.settings.extras.memory_every_s
            rec.sample_processes(sim_now(), {"runner": os.getpid(), **supervisor.pids()},
                                 supervisor.process_robots())
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
    rec.sample_processes(sim_now(), {"runner": os.getpid(), **supervisor.pids()},
                         supervisor.process_robots())


def _teardown(parts: RunParts, reason: str) -> str:
    """Stop the robots, close the bus and the server, free the CPUs; the end reason (a
    server that fails to stop makes it a server error)."""
    from player_server.server.affinity import pin_current_thread

    parts.supervisor.stop_all()
    for events_tail, auctions_tail in parts.tails.values():
        events_tail.close()
        auctions_tail.close()
    if parts.loop.log_writes is not None:
        parts.loop.log_writes.close()
    parts.node.close()
    parts.transport.close()
    try:
        parts.server.stop()
    except RuntimeError as exc:
        log.error("server: %s", exc)
        reason = "server-error"
    parts.sim.close()
    if parts.split is not None and parts.own_cpus is not None:
        pin_current_thread(parts.own_cpus)  # the report may use every CPU again
    return reason


def finish(parts: RunParts, reason: str) -> int:
    """Write the report, print the end of the run; the exit code (0 completed, 1 stopped
    otherwise, 3 an invariant broken, or the experiment's own verdict)."""
    from experiments import events as ev
    from experiments.end_report import end_of_run_lines
    from experiments.summary import terminal_state_problems

    settings, rec, experiment = parts.settings, parts.rec, parts.settings.experiment
    keep_viewer = settings.meshcat and reason == "completed"
    bus_loss = parts.bus_loss
    report = rec.finish(reason, replay=settings.replay, plots=settings.plots,
                        end_t=parts.loop.state.last_t, keep_viewer=keep_viewer,
                        extra=({"bus_loss_runner": {"dropped": bus_loss.dropped,
                                                    "delayed": bus_loss.delayed}}
                               if bus_loss is not None else None))
    problems = terminal_state_problems(ev.read_events(rec.run.events))
    s = report.summary
    for line in experiment.end_lines(parts.referee):
        click.echo(line)
    for line in end_of_run_lines(experiment=experiment.name, reason=reason,
                                 run_root=rec.run.root, summary=s, plots=report.plots,
                                 replay=report.replay, problems=report.problems):
        click.echo(line)
    click.echo(f"events sha256 {s['events_sha256']} (a lockstep run with the same world, seed "
               f"and options writes the same events.jsonl)" if settings.lockstep
               else f"events sha256 {s['events_sha256']}")
    if keep_viewer:
        rec.hold_viewer(signal.pause)
    if any(problems.values()):
        click.echo(f"invariant broken: {problems}", err=True)
        return 3
    verdict = experiment.verdict(s)
    if verdict is not None:
        click.echo(verdict.message, err=True)
        return verdict.exit_code
    return 0 if reason == "completed" else 1
