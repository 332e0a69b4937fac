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
import math
import os
import random
import re
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import click

log = logging.getLogger("murdoch.run")

EXPERIMENT_WORLDS = {"longterm": "longterm", "boxpush": "boxpush"}
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


def _start_robot(rp: RobotProcess, args: list[str], log_path: Path, nice: int = 0) -> None:
    rp.log_file = log_path.open("ab")
    rp.proc = subprocess.Popen(args, stdout=rp.log_file, stderr=subprocess.STDOUT,
                               stdin=subprocess.DEVNULL)
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
@click.option("--until", "until", default=None, help="Simulated duration, e.g. 90m, 2h.")
@click.option("--speedup", type=float, default=0.0, show_default=True,
              help="Simulated seconds per wall second; 0 = as fast as possible (lockstep).")
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
@click.option("--no-replay", is_flag=True, help="Do not write replay.html.")
@click.option("--pipelined/--no-pipelined", default=True, show_default=True,
              help="Lockstep: the server sends each round before it steps and computes the "
                   "next one while the robots work (their commands act one tick later).")
@click.option("--robot-nice", type=click.IntRange(0, 19), default=0, show_default=True,
              help="Niceness of the robot processes: above 0 the simulator's serving thread, "
                   "which every robot waits on, wins the CPU when both are ready to run.")
@click.option("--pin-cpus/--no-pin-cpus", default=True, show_default=True,
              help="Give the simulator's serving thread a CPU of its own and run everything "
                   "else (robots, runner) on the others (Linux, at least two CPUs).")
def run(experiment: str, sim_hours: float | None, until: str | None, speedup: float, seed: int,
        meshcat: bool, out: Path, world: str | None, task_interval: float,
        kills: tuple[str, ...], restarts: tuple[str, ...], switch_offs: tuple[str, ...],
        switch_ons: tuple[str, ...], goal_radius: float | None, no_replay: bool,
        pipelined: bool, robot_nice: int, pin_cpus: bool) -> None:
    """Run EXPERIMENT end to end and leave a run directory behind."""
    if sim_hours is not None and until is not None:
        raise click.UsageError("give --sim-hours or --until, not both")
    duration_s = (sim_hours * 3600.0 if sim_hours is not None
                  else parse_duration_s(until) if until is not None else 600.0)
    code = run_experiment(
        experiment=experiment, duration_s=duration_s, speedup=speedup, seed=seed,
        meshcat=meshcat, out=out, world_name=world or EXPERIMENT_WORLDS[experiment],
        task_interval_s=task_interval, kills=[parse_at(k) for k in kills],
        restarts=[parse_at(r) for r in restarts], replay=not no_replay,
        switch_offs=[parse_at(r) for r in switch_offs],
        switch_ons=[parse_at(r) for r in switch_ons], goal_radius_m=goal_radius,
        pipelined=pipelined, robot_nice=robot_nice, pin_cpus=pin_cpus,
    )
    sys.exit(code)


def run_experiment(
    *, experiment: str, duration_s: float, speedup: float, seed: int, meshcat: bool, out: Path,
    world_name: str, task_interval_s: float, kills: list[tuple[str, float]],
    restarts: list[tuple[str, float]], replay: bool,
    switch_offs: list[tuple[str, float]] | None = None,
    switch_ons: list[tuple[str, float]] | None = None, goal_radius_m: float | None = None,
    pipelined: bool = True, robot_nice: int = 0, pin_cpus: bool = False,
) -> int:
    from behaviors.library import TASKS
    from experiments import boxpush as bp
    from experiments import events as ev
    from experiments.observe import JsonlTail, robot_event_to_run_events
    from experiments.recorder import RunRecorder
    from experiments.summary import terminal_state_problems
    from experiments.task_source import boxpush_task, longterm_tasks
    from murdoch.auction.messages import TaskSpec
    from murdoch.multicast import MulticastConfig, MulticastTransport
    from murdoch.node import Node
    from murdoch.user_agent import RandomizedBackoff
    from player_server.server.affinity import allowed_cpus, pin_current_thread, plan_split
    from player_server.server.assembly import world_endpoints
    from player_server.server.core import CoreConfig
    from player_server.server.runner import PlayerServer
    from player_server.sim import Simulation
    from worlds import load_world, world_path

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    wpath = Path(world_name)
    spec = load_world(wpath if wpath.suffix == ".toml" else world_path(world_name))
    lockstep = speedup == 0
    switch_offs, switch_ons = list(switch_offs or ()), list(switch_ons or ())
    names = [r.name for r in spec.robots]
    try:
        switch_offs = [(bp.resolve_robot(r, names), t) for r, t in switch_offs]
        switch_ons = [(bp.resolve_robot(r, names), t) for r, t in switch_ons]
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from exc
    if (switch_offs or switch_ons) and experiment != "boxpush":
        raise click.UsageError("--switch-off/--switch-on are for the boxpush experiment")
    goal_watch = actions = None
    if experiment == "boxpush":
        goal_watch = bp.GoalWatch(bp.box_goal(spec), goal_radius_m or bp.GOAL_RADIUS_M,
                                 tuple(r.name for r in spec.robots if r.mobile))
        actions = bp.SimActions()
    mcast_port = free_udp_port()
    own_cpus = allowed_cpus()
    split = plan_split(own_cpus) if pin_cpus and own_cpus is not None else None
    config = {
        "experiment": experiment, "seed": seed, "world": str(spec.source),
        "duration_s": duration_s, "speedup": speedup, "lockstep": lockstep,
        "task_interval_s": task_interval_s, "multicast_port": mcast_port,
        "pipelined": lockstep and pipelined, "robot_nice": robot_nice,
        "cpu_affinity": split.as_dict() if split is not None else None,
        "kills": [f"{r}@{t:g}s" for r, t in kills],
        "restarts": [f"{r}@{t:g}s" for r, t in restarts],
    }
    if goal_watch is not None:
        config.update({
            "switch_offs": [f"{r}@{t:g}s" for r, t in switch_offs],
            "switch_ons": [f"{r}@{t:g}s" for r, t in switch_ons],
            "goal_radius_m": goal_watch.radius_m,
        })
    rec = RunRecorder(out, experiment, config, world=spec, started=datetime.now(),
                      wall_clock=time.monotonic, stream=sys.stdout, meshcat=meshcat)
    click.echo(f"run directory: {rec.run.root}")
    sim = Simulation(spec, seed=seed)
    endpoints = world_endpoints(spec, sim, 0)
    if split is not None:
        # this thread, and so every thread and robot process started from now on, keeps off
        # the serving thread's CPU
        pin_current_thread(split.others)
    samplers: tuple[tuple[float, Any], ...] = ()
    if goal_watch is not None and actions is not None:
        samplers = ((0.5, goal_watch.sample), (0.0, actions.apply))
    server = PlayerServer(
        rec.observe(sim, samplers=samplers), endpoints, interval_s=sim.interval_s,
        clock=time.monotonic,
        speedup=speedup, quit_time_s=duration_s,
        config=CoreConfig(lockstep=lockstep,
                          lockstep_clients=max(1, sum(1 for e in endpoints if e.mobile)),
                          lockstep_timeout_s=5.0, pipelined=pipelined),
        cpus=split.serving if split is not None else None,
    )
    robots: dict[str, RobotProcess] = {}
    tails: dict[str, JsonlTail] = {}
    introduced_tasks: set[str] = set()
    finished_tasks: set[str] = set()
    auction_tails: dict[str, JsonlTail] = {}
    unachievable_reasons: dict[str, str] = {}

    def sim_pose_of(name: str) -> tuple[float, float, float]:
        poses = goal_watch.robot_poses if goal_watch is not None else {}
        return poses.get(name, (0.0, 0.0, 0.0))
    stop_requested = [False]

    def on_signal(signum: int, frame: object) -> None:
        stop_requested[0] = True

    old_int = signal.signal(signal.SIGINT, on_signal)
    old_term = signal.signal(signal.SIGTERM, on_signal)
    transport = node = None
    drain_tails: Any = None
    reason = "completed"
    try:
        rec.start()
        server.start()
        ports = server.ports

        def robot_args(name: str) -> list[str]:
            return [*_robot_command(), "-p", str(ports[name]),
                    "--name", name, "--world", str(spec.source), "--mcast-port",
                    str(mcast_port), "--seed", str(seed),
                    "--events", str(rec.run.logs / f"{name}.events.jsonl"),
                    "--auction-log", str(rec.run.logs / f"{name}.auction.jsonl")]

        for ep in endpoints:
            rp = RobotProcess(ep.name, ports[ep.name])
            _start_robot(rp, robot_args(ep.name), rec.run.log_file(f"robot-{ep.name}"),
                         robot_nice)
            robots[ep.name] = rp
            tails[ep.name] = JsonlTail(rec.run.logs / f"{ep.name}.events.jsonl")
            auction_tails[ep.name] = JsonlTail(rec.run.logs / f"{ep.name}.auction.jsonl")

        def drain_tails() -> None:
            for tail in tails.values():
                for d in tail.read_new():
                    for e in robot_event_to_run_events(d):
                        rec.event(e.pop("t"), e.pop("kind"), **e)
            for tail in auction_tails.values():
                for d in tail.read_new():
                    if "time_s" in d and "kind" in d:
                        on_auction_event(d)

        sim_now = lambda: float(sim.time_s)  # noqa: E731 - a float read across threads
        transport = MulticastTransport("user", sim_now, MulticastConfig(port=mcast_port))
        announced_at: dict[str, float] = {}
        finished_tasks.clear()

        def on_message(envelope: Any) -> None:
            msg = envelope.message
            fields = {"task": getattr(msg, "task_id", None)} if hasattr(msg, "task_id") else {}
            rec.event(sim_now(), ev.MESSAGE, msg_kind=envelope.kind, sender=envelope.sender,
                      bytes=envelope.size_bytes, **fields)

        monitor = transport.subscribe(None, on_message)

        def on_auction_event(d: dict[str, Any]) -> None:
            """An auctioneer's event (the runner's own or a robot's) as run events."""
            kind, task_id, t = d.get("kind"), str(d.get("task_id")), float(d["time_s"])
            if kind == "announce":
                if task_id not in announced_at and d.get("agent") != "user":
                    rec.event(t, ev.TASK_INTRODUCED, task=task_id, task_kind=d.get("name", ""),
                              source=d.get("agent"))
                    introduced_tasks.add(task_id)
                announced_at[task_id] = t
            elif kind == "award":
                latency = t - announced_at.get(task_id, t)
                rec.event(t, ev.AWARD, task=task_id, robot=d.get("winner"),
                          bid=d.get("score"), latency_s=round(latency, 4))
            elif kind == "reallocation":
                rec.event(t, ev.REALLOCATION, task=task_id, from_robot=d.get("winner"),
                          reason=d.get("reason", ""))
            elif kind == "outcome" and task_id not in finished_tasks:
                why = str(d.get("reason", ""))
                if d.get("status") == "unachievable" or why.startswith("unachievable"):
                    unachievable_reasons[task_id] = why or "unachievable"
                rec.event(t, ev.TASK_OUTCOME, task=task_id, outcome=d.get("status"),
                          robot=d.get("winner"), reason=d.get("reason", ""))
                finished_tasks.add(task_id)

        def observer(e: Any) -> None:
            on_auction_event(e.to_dict())

        node = Node(transport, sim_now, agent_id="user", observer=observer,
                    backoff=RandomizedBackoff(random.Random(seed), base_s=5.0, cap_s=60.0))
        if experiment == "boxpush":
            planned = iter([boxpush_task(spec, duration_s), None])
        else:
            planned = longterm_tasks(spec, random.Random(seed + 1),
                                     mean_interval_s=task_interval_s)
        next_task = next(planned)
        main_task: str | None = None
        end_after_s: float | None = None
        schedule = sorted([(t, "kill", r) for r, t in kills]
                          + [(t, "restart", r) for r, t in restarts]
                          + [(t, "switch-off", r) for r, t in switch_offs]
                          + [(t, "switch-on", r) for r, t in switch_ons])
        switched_off: dict[str, float] = {}  # robot -> its side along the box when switched off
        goal_outcome: str | None = None
        next_memory_t = 60.0  # first sample once every process is up and running
        busy_killed: list[str] = []
        next_tail_wall = 0.0
        mobile = {r.name for r in spec.robots if r.mobile}
        while not server.finished.is_set() and not stop_requested[0]:
            now = sim_now()
            while next_task is not None and next_task.t_s <= now and next_task.t_s < duration_s:
                kind = next_task.kind
                task_spec = TaskSpec(kind, TASKS[kind].subjects, next_task.params,
                                     duration_s=float(next_task.params.get("duration_s", 0.0)),
                                     bid_window_s=1.0, renew_period_s=2.0,
                                     contract_timeout_s=10.0, abandon_after_s=10.0,
                                     timeout_s=float(next_task.params["duration_s"]) + 600.0)
                task_id = node.announce(task_spec, patience_s=300.0)
                rec.event(now, ev.TASK_INTRODUCED, task=task_id, task_kind=kind,
                          params=next_task.params, source="user")
                introduced_tasks.add(task_id)
                main_task = main_task or task_id
                next_task = next(planned)
            if goal_watch is not None and goal_outcome is None:
                if goal_watch.reached_at_s is not None:
                    goal_outcome = "reached"
                    rec.event(goal_watch.reached_at_s, ev.GOAL_REACHED, box=goal_watch.bg.box,
                              distance_m=round(goal_watch.distance_m, 3),
                              radius_m=goal_watch.radius_m)
                    click.echo(f"goal reached at {goal_watch.reached_at_s:.1f} s simulated: "
                               f"box {goal_watch.distance_m:.2f} m from the goal")
                elif main_task is not None and main_task in unachievable_reasons:
                    goal_outcome = "unachievable"
                    why = unachievable_reasons[main_task]
                    rec.event(now, ev.GOAL_UNACHIEVABLE, task=main_task, reason=why)
                    click.echo(f"error: the box cannot be pushed to the goal: {why}", err=True)
            if experiment == "boxpush" and (main_task in finished_tasks
                                            or goal_outcome is not None):
                # the box reached the goal (or could not): let the last reports arrive, then stop
                end_after_s = end_after_s if end_after_s is not None else now + 3.0
                if now >= end_after_s:
                    break
            while schedule and schedule[0][0] <= now:
                _, action, name = schedule.pop(0)
                if name == "busy":  # the first robot (by name) that holds a task now
                    if action == "kill":
                        working = [r for r, st in sorted(rec.robot_states().items())
                                   if st == "working" and r in mobile]
                        busy_killed.append(working[0] if working else "")
                    name = busy_killed[-1] if busy_killed else ""
                target = robots.get(name)
                if target is None:
                    log.warning("no robot %s to %s", name, action)
                elif action == "switch-off":
                    _stop_robot(target, kill=True)
                    box_pose = goal_watch.box_pose if goal_watch is not None else None
                    xy = sim_pose_of(name)
                    side = bp.side_of(box_pose, xy[:2]) if box_pose is not None else 0.0
                    switched_off[name] = side
                    spot = bp.park_pose(spec, sorted(robots).index(name))
                    actions.put(lambda s, n=name, p=spot: _place(s, n, p))  # type: ignore[union-attr]
                    rec.event(now, ev.ROBOT_SWITCH_OFF, robot=name, side_m=round(side, 3))
                elif action == "switch-on":
                    side = switched_off.pop(name, 0.0)
                    box_pose = goal_watch.box_pose if goal_watch is not None else None
                    assert goal_watch is not None and actions is not None and box_pose is not None
                    # the other end of the box from where it was
                    other = -math.copysign(max(abs(side), 0.3), side or 1.0)
                    other = max(-goal_watch.bg.box_half_length_m + 0.2,
                                min(goal_watch.bg.box_half_length_m - 0.2, other))
                    pose = bp.return_pose(box_pose, goal_watch.bg.goal_xy, other, goal_watch.bg)
                    start = next(r.pose for r in spec.robots if r.name == name)
                    odo = bp.odometry_at((start[0], start[1], start[2]), pose)
                    # placed by hand and told where it is: odometry stays in the shared frame
                    actions.put(lambda s, n=name, p=pose, o=odo: _place(s, n, p, o))
                    if target.proc is None or target.proc.poll() is not None:
                        _start_robot(target, robot_args(name),
                                     rec.run.log_file(f"robot-{name}"), robot_nice)
                    assert target.proc is not None
                    rec.event(now, ev.ROBOT_SWITCH_ON, robot=name, x=round(pose[0], 3),
                              y=round(pose[1], 3), yaw=round(pose[2], 3), pid=target.proc.pid)
                elif action == "kill":
                    pid = target.proc.pid if target.proc is not None else None
                    _stop_robot(target, kill=True)
                    rec.event(now, ev.ROBOT_FAILURE, robot=name, reason="killed", pid=pid)
                else:
                    _start_robot(target, robot_args(name), rec.run.log_file(f"robot-{name}"),
                                 robot_nice)
                    assert target.proc is not None
                    rec.event(now, ev.ROBOT_RESTART, robot=name, pid=target.proc.pid)
            node.step(0.02)
            wall = time.monotonic()
            if wall >= next_tail_wall:  # robots' own events, a few times a second
                next_tail_wall = wall + 0.25
                drain_tails()
            if now >= next_memory_t:
                next_memory_t = now + 300.0
                pids = {"runner": os.getpid()}
                pids.update({f"robot-{n}": rp.proc.pid for n, rp in robots.items()
                             if rp.proc is not None and rp.proc.poll() is None})
                rec.sample_processes(now, pids)
            rec.advance(now)
            rec.tick()
        if stop_requested[0]:
            reason = "interrupted"
        if server.error is not None:
            reason = "server-error"
        # tasks still open when the run ends fail with a reason: one terminal state each
        end = sim_now()
        end_why = "run ended: box at the goal" if goal_outcome == "reached" else "run ended"
        for task_id in node.auctioneer.open_tasks():
            node.auctioneer.cancel(task_id, end, end_why)
        node.step(0.0)
        pids = {"runner": os.getpid()}
        pids.update({f"robot-{n}": rp.proc.pid for n, rp in robots.items()
                     if rp.proc is not None and rp.proc.poll() is None})
        rec.sample_processes(end, pids)
        monitor.close()
    except Exception:
        log.exception("the run failed")
        reason = "error"
    finally:
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, old_term)
        for rp in robots.values():
            _stop_robot(rp)
        if drain_tails is not None:
            try:
                drain_tails()  # what the robots wrote before they stopped
            except Exception:
                log.exception("reading the robots' last events")
        # sub-tasks that robots were still auctioning when they stopped end here
        end_t = float(sim.time_s)
        for task_id in sorted(introduced_tasks - finished_tasks):
            rec.event(end_t, ev.TASK_OUTCOME, task=task_id, outcome=ev.FAILED,
                      reason="run ended")
        if node is not None:
            node.close()
        if transport is not None:
            transport.close()
        try:
            server.stop()
        except RuntimeError as exc:
            log.error("server: %s", exc)
            reason = "server-error"
        sim.close()
        if split is not None and own_cpus is not None:
            pin_current_thread(own_cpus)  # the report may use every CPU again
    report = rec.finish(reason, replay=replay)
    problems = terminal_state_problems(ev.read_events(rec.run.events))
    s = report.summary
    click.echo(
        f"done: {s['sim_time_s']:.0f} s simulated in {s['wall_time_s']} s "
        f"(rtf {s['real_time_factor']}); tasks executed {s['tasks']['executed']}, "
        f"unachievable {s['tasks']['unachievable']}, failed {s['tasks']['failed']}, "
        f"charging trips {s['charging_trips']}; {rec.run.root}"
    )
    if any(problems.values()):
        click.echo(f"invariant broken: {problems}", err=True)
        return 3
    goal = s.get("goal")
    if goal is not None and goal.get("unachievable"):
        click.echo(f"unachievable: {goal.get('unachievable_reason')}", err=True)
        return 4
    return 0 if reason == "completed" else 1
