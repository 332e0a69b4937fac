"""`murdoch-robot`: one robot's client process.

    murdoch-robot -p 6665 [-h 127.0.0.1] [--name r1] [--world longterm]
                  [--task goto-goal --param x=1 --param y=2] [--events run/r1.jsonl]
                  [--mcast-port 5xxxx [--mcast-group 239.255.74.17] [--auction-log F]]
                  [--allocator murdoch|cbba|cbga [--refine]] [--metric distance,specialist]

Connects to the robot's port, subscribes to every device listed there, derives the robot's
resource subjects and runs until SIGINT/SIGTERM (or, with --exit-when-done, until its task
ends). Events (JSON lines) go to --events ("-" = stdout). With --mcast-port the robot joins
MURDOCH on that loopback multicast group (`behaviors.murdoch_link`): it offers its subjects,
bids on announcements with its tasks' metrics and runs the tasks it wins. `--allocator`
picks the team's allocator from `murdoch.allocators` (MURDOCH auctions by default; CBBA or
CBGA plan paths of tasks by consensus, with the world's robots as the team); `--refine` adds
the consensus allocators' improvement phase (`murdoch.allocators.consensus_refine`).

With ``MURDOCH_ROBOT_PROFILE_DIR`` set, a MURDOCH robot writes a cProfile of its main loop, in
the main thread's CPU time, to ``<dir>/<name>.prof`` when it stops.
"""

from __future__ import annotations

import argparse
import cProfile
import gc
import json
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import IO, Any

from behaviors.battery import BatteryPolicy
from behaviors.cut import AbortableClient, Cut
from behaviors.events import TASK_DONE, TASK_FAILED, TASK_STOPPED, Event, EventLog
from behaviors.library import parse_bid_terms
from behaviors.params import ParamError, parse_assignments
from behaviors.robot import build_agent
from behaviors.task_kinds import task_kinds
from murdoch.allocators import ALLOCATORS, REFINABLE
from murdoch.allocators import DEFAULT as DEFAULT_ALLOCATOR
from murdoch.plugin_loading import PluginError
from player_server.client import (
    PlayerClient,
    PlayerConnectionClosed,
    PlayerConnectionError,
    PlayerError,
)

log = logging.getLogger("murdoch-robot")
PROFILE_ENV = "MURDOCH_ROBOT_PROFILE_DIR"
KEY_ENV = "MURDOCH_TEAM_KEY"
EPOCH_ENV = "MURDOCH_RUN_EPOCH"
STALE_AFTER_TICKS = 100
"""Outside lockstep, datagrams stamped more than this many ticks (10 s) ago are refused."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="murdoch-robot", add_help=False,
        description="Run one robot: connect to its Player port, run basis behaviours and tasks.",
    )
    p.add_argument("--help", action="help", help="show this help and exit")
    p.add_argument("-p", "--port", type=int, required=True, help="the robot's Player port")
    p.add_argument("-h", "--host", default="127.0.0.1", help="server host (default 127.0.0.1)")
    p.add_argument("--name", default="", help="robot name (default robot-PORT)")
    p.add_argument("--world", default="", help="world name or .toml path (chargers, camera)")
    kinds = sorted(task_kinds())
    p.add_argument("--task", default=None, choices=kinds, metavar="TASK",
                   help="task to run at once, one of: " + ", ".join(kinds))
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="task parameter (repeatable)")
    p.add_argument("--task-id", default="cli", help="id reported with the task's events")
    p.add_argument("--exit-when-done", action="store_true", help="exit when the task ends")
    p.add_argument("--max-ticks", type=int, default=0, help="stop after N ticks (0 = never)")
    p.add_argument("--events", default="", help="append events as JSON lines here ('-' = stdout)")
    p.add_argument("--battery-low", type=float, default=25.0, help="charge below this %%")
    p.add_argument("--battery-resume", type=float, default=95.0, help="charge up to this %%")
    p.add_argument("--no-battery", action="store_true", help="never go charging")
    p.add_argument("--seed", type=int, default=0, help="seed for wandering")
    p.add_argument("--images", action="store_true", help="also subscribe raw camera images")
    p.add_argument("--mcast-port", type=int, default=0,
                   help="join MURDOCH on this loopback multicast port (0 = do not)")
    p.add_argument("--mcast-group", default="239.255.74.17", help="MURDOCH multicast group")
    p.add_argument("--transport", choices=("multicast", "zenoh"), default="multicast",
                   help="MURDOCH's transport: loopback UDP multicast (--mcast-port) or Zenoh "
                        "as a client of the team's hub (--zenoh-endpoint); default multicast")
    p.add_argument("--zenoh-endpoint", default="tcp/127.0.0.1:7447",
                   help="--transport zenoh: the team hub's tcp/ADDRESS:PORT "
                        "(default tcp/127.0.0.1:7447)")
    p.add_argument("--zenoh-allow-remote", action="store_true",
                   help="--transport zenoh: allow a hub address other than 127.0.0.1 (a robot "
                        "on another host)")
    p.add_argument("--lockstep-bus", action="store_true",
                   help="lockstep run: act on MURDOCH datagrams at tick boundaries in tick order "
                        "(needs the server's team clock device, opaque:0)")
    p.add_argument("--request-timeout", type=float, default=60.0, metavar="S",
                   help="give up on a request to the server after S wall seconds (default 60: "
                        "a server may be compiling its sensing kernels on first use)")
    p.add_argument("--read-timeout", type=float, default=60.0, metavar="S",
                   help="give up waiting for a data round after S wall seconds (default 60; a "
                        "lockstep run, whose pace is set by the slowest robot, passes more)")
    p.add_argument("--instance", default="",
                   help="this process's MURDOCH instance label (default: drawn at random; a run "
                        "numbers each start of a robot 0, 1, ...)")
    p.add_argument("--auction-log", default="",
                   help="append this robot's auctioneer and bidder events (JSON lines) here")
    p.add_argument("--allocator", default=DEFAULT_ALLOCATOR, choices=list(ALLOCATORS),
                   help="the team's allocator (default murdoch): " + ", ".join(ALLOCATORS))
    p.add_argument("--refine", action="store_true",
                   help="cbba, cbga: improve each settled plan by agreed exchanges before "
                        "claiming (see docs/allocators.md)")
    p.add_argument("--metric", default="",
                   help="optional terms added to every task's metric, comma-separated: "
                        "distance, specialist (default: none)")
    p.add_argument("--log-level", default="WARNING", help="logging level (default WARNING)")
    return p


def stop_on_signals() -> threading.Event:
    """An event set by SIGINT or SIGTERM; a second signal exits at once."""
    stop = threading.Event()
    signals_seen = [0]

    def on_signal(signum: int, frame: FrameType | None) -> None:
        signals_seen[0] += 1
        stop.set()
        if signals_seen[0] > 1:
            raise SystemExit(130)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    return stop


def _step_until_stopped(link: Any, stop: threading.Event, max_ticks: int | None,
                        name: str) -> None:
    """Step the robot and its MURDOCH node until stopped (profiled when asked to)."""
    profile_dir = os.environ.get(PROFILE_ENV)
    profiler = cProfile.Profile(time.thread_time) if profile_dir else None
    if profiler is not None:
        profiler.enable()
    ticks = 0
    try:
        while not stop.is_set() and (not max_ticks or ticks < max_ticks):
            link.step()
            ticks += 1
    finally:
        if profiler is not None and profile_dir:
            profiler.disable()
            profiler.dump_stats(os.path.join(profile_dir, f"{name}.prof"))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The robot's options, checked (argparse's usage error and exit on a wrong one; a
    broken task kind plugin is one line and exit status 2)."""
    try:
        parser = _parser()
    except PluginError as exc:
        say(f"murdoch-robot: {exc}")
        raise SystemExit(2) from None
    args = parser.parse_args(argv)
    if ALLOCATORS.problems:
        parser.error(ALLOCATORS.problems[0])
    if args.refine and args.allocator not in REFINABLE:
        parser.error(f"--refine is for the consensus allocators ({', '.join(REFINABLE)}), "
                     f"not --allocator {args.allocator}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s %(name)s %(levelname)s %(message)s")
    return run_robot(args, stop_on_signals(), on_ready=freeze_start_up)


def freeze_start_up() -> None:
    """What start-up built lives as long as the process: keep it out of the collector's
    way, so the collections the tick's short-lived objects trigger stay small."""
    gc.collect()
    gc.freeze()


def say(line: str) -> None:
    """A line on standard error, written whole (robots sharing a process write there too)."""
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def run_robot(args: argparse.Namespace, stop: threading.Event, *,
              label: str = "murdoch-robot", cut: Cut | None = None,
              on_ready: Callable[[], None] | None = None) -> int:
    """One robot, from connecting to its port until `stop` is set (or its task ends with
    --exit-when-done, or the server goes); its exit code. What a `murdoch-robot` process
    runs, and what each robot thread of a host process runs (`behaviors.host`): there `cut`
    stands in for killing the robot (its logs are written through it, its connection and
    transport aborted by it) and messages start with `label`. `on_ready` runs once the
    robot is built, before it starts stepping."""
    try:
        params = parse_assignments(args.param)
        terms = parse_bid_terms(args.metric)
    except ParamError as exc:
        say(f"{label}: {exc}")
        return 2
    world = None
    if args.world:
        from worlds import WorldError, load_world, world_path

        try:
            path = Path(args.world) if args.world.endswith(".toml") else world_path(args.world)
            world = load_world(path)
        except (WorldError, OSError, KeyError, ValueError) as exc:
            say(f"{label}: cannot load world {args.world!r}: {exc}")
            return 2
    name = args.name or f"robot-{args.port}"
    opened = (open(args.events, "a", encoding="utf-8")  # noqa: SIM115 (closed below)
              if args.events not in ("", "-") else None)
    stream = sys.stdout if args.events == "-" else opened
    events = EventLog(cut.gate(stream) if stream is not None and cut is not None else stream)

    if args.exit_when_done:
        def on_event(event: Event) -> None:
            if event.kind in (TASK_DONE, TASK_FAILED, TASK_STOPPED) and event.task in task_kinds():
                stop.set()

        events.add_sink(on_event)

    battery = None if args.no_battery else BatteryPolicy(args.battery_low, args.battery_resume)
    client = AbortableClient(args.host, args.port,
                             lockstep=True if args.lockstep_bus else None,
                             timeout_s=args.request_timeout, read_timeout_s=args.read_timeout)
    code = 0
    auction_log: IO[str] | None = None
    transport = link = None
    try:
        if cut is not None:
            cut.hold(client.abort)  # ends a handshake under way
        client.connect()
        if cut is not None:
            cut.hold(client.abort)  # at once if the robot was cut off before connecting
        agent = build_agent(client, name, world=world, events=events, battery=battery,
                            seed=args.seed, subscribe_images=args.images, bid_terms=terms)
        if on_ready is not None:
            on_ready()
        status = {"robot": name, "port": args.port, "subjects": sorted(agent.subjects())}
        say(json.dumps({"ready": status}))
        if args.task:
            agent.start_task(args.task, params, args.task_id)
        if args.mcast_port or args.transport == "zenoh":
            if args.auction_log:
                auction_log = open(args.auction_log, "a", encoding="utf-8")  # noqa: SIM115
            transport, sync = _team_transport(args, name, agent, client, world)
            if cut is not None:
                cut.hold(transport.close)
            link = _link(args, agent, transport, sync, events, world,
                         cut.gate(auction_log) if cut is not None and auction_log
                         else auction_log)
            _step_until_stopped(link, stop, args.max_ticks, name)
        else:
            agent.run(stop, max_ticks=args.max_ticks or None)
    except ParamError as exc:
        say(f"{label}: {exc}")
        code = 2
    except PlayerConnectionClosed:
        # the server stopped (a run ending closes every robot's connection): a normal stop
        if not stop.is_set():
            log.info("the server closed the connection; stopping")
    except PlayerConnectionError as exc:
        if not stop.is_set():
            say(f"{label}: {exc}")
            code = 1
    except PlayerError as exc:
        say(f"{label}: {exc}")
        code = 1
    finally:
        if link is not None and (cut is None or not cut.is_cut):
            link.close()  # a robot cut off says nothing more
        if transport is not None:
            transport.close()
        client.close()
        if auction_log is not None:
            auction_log.close()
        if opened is not None:
            opened.close()
    return code


def _link(args: argparse.Namespace, agent: Any, transport: Any, sync: Any, events: EventLog,
          world: Any, auction_log: IO[str] | None) -> Any:
    """The robot's link to its team's allocator (`behaviors.murdoch_link`)."""
    from behaviors.murdoch_link import MurdochLink

    speed = agent.profile.max_speed_mps if "mobile" in agent.subjects() else 0.0
    return MurdochLink(agent, transport, events, auction_log, tick_sync=sync,
                       allocator_name=args.allocator, team=_team(world, agent.name),
                       speed_mps=speed, refine=args.refine)


def _team(world: Any, name: str) -> tuple[str, ...]:
    """Every member of the team in the world's order (its robots, then the overhead camera's
    desk), the order consensus allocators index agents by; this robot is always in it."""
    team: tuple[str, ...] = ()
    if world is not None:
        team = tuple(r.name for r in world.robots)
        if world.overhead_camera is not None:
            team = (*team, world.overhead_camera.name)
    return team if name in team else (*team, name)


def _team_transport(args: argparse.Namespace, name: str, agent: Any, client: PlayerClient,
                    world: Any) -> tuple[Any, Any]:
    """The robot's MURDOCH transport (keyed and stamped with the run's epoch when the run
    gives them, through the environment) and, in a lockstep run, its tick sync."""
    from behaviors.murdoch_link import TickSync
    from murdoch.auth import TeamKey
    from murdoch.endpoint import EndpointOptions
    from murdoch.lossy import ENV as LOSS_ENV
    from murdoch.lossy import LossSpec, LossyReceiver
    from murdoch.multicast import MulticastConfig
    from murdoch.transport import TickConfig
    from murdoch.transport_choice import TransportChoice, open_transport
    from murdoch.zenoh_transport import ZenohConfig, ZenohUnavailable
    from player_server.client import OpaqueProxy

    interval_s = world.sim.interval_sim_s if world is not None else 0.1
    secret = os.environ.get(KEY_ENV, "")
    key = TeamKey(secret) if secret else None

    def tick() -> int:
        return round(float(agent.status().time_s) / interval_s)

    ticks = TickConfig(tick, epoch=os.environ.get(EPOCH_ENV, ""), ordered=args.lockstep_bus,
                       stale_after_ticks=0 if args.lockstep_bus else STALE_AFTER_TICKS,
                       require_tick=key is not None)
    loss_text = os.environ.get(LOSS_ENV, "")
    loss = (LossyReceiver(LossSpec.parse(loss_text), name, time.monotonic)
            if loss_text and not args.lockstep_bus else None)
    try:
        if args.transport == "zenoh":
            choice = TransportChoice("zenoh", zenoh=ZenohConfig(
                endpoint=args.zenoh_endpoint, allow_remote=args.zenoh_allow_remote))
            loss = None  # the loss layer is the multicast receiver's
        else:
            choice = TransportChoice("multicast", multicast=MulticastConfig(
                group=args.mcast_group, port=args.mcast_port))
        transport = open_transport(
            choice, name, lambda: float(agent.status().time_s),
            EndpointOptions(codec=ALLOCATORS[args.allocator].codec, key=key,
                            instance=args.instance or None, ticks=ticks), loss=loss)
    except (ValueError, ZenohUnavailable, OSError) as exc:
        raise PlayerError(f"cannot join the team's bus: {exc}") from None
    sync = None
    if args.lockstep_bus:
        clock = client.proxies.get((OpaqueProxy.interf, 0))
        if not isinstance(clock, OpaqueProxy):
            transport.close()
            raise PlayerError("--lockstep-bus needs the server's team clock device (opaque:0)")
        sync = TickSync(clock, transport, interval_s, time.monotonic)
    return transport, sync


if __name__ == "__main__":
    sys.exit(main())
