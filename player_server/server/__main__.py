"""``player-server WORLD.toml``: serve every robot of a world over the Player protocol."""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from player_server.protocol.constants import DEFAULT_PORT
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer
from player_server.server.serve_loop import serve_until_done
from player_server.server.stage_assembly import plan_endpoints
from player_server.server.stage_source import (
    is_stage_source,
    load_stage_source,
    table_json,
    write_atomically,
)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="player-server", add_help=False,
        description="Serve the robots of a world over the Player 3.x protocol "
                    "(one port per robot, starting at the base port).")
    p.add_argument("--help", action="help", help="show this help and exit")
    p.add_argument("world", nargs="?",
                   help="world file (.toml), Stage world (.world), Player configuration "
                        "(.cfg) or the name of a bundled world")
    p.add_argument("--replay", metavar="RUN.mcap", default=None,
                   help="serve a run recording (run.mcap or its run directory) instead of a "
                        "world: the recorded robots, commands ignored")
    p.add_argument("-p", "--port", type=int, default=DEFAULT_PORT,
                   help="base port (default %(default)s; 0 = ephemeral ports)")
    p.add_argument("-h", "--host", "--bind", dest="host", default="127.0.0.1",
                   help="address to bind (default %(default)s; another address only when "
                        "robots on other hosts must reach the server)")
    p.add_argument("--speedup", type=float, default=None,
                   help="simulated seconds per wall second, 0 = as fast as possible "
                        "(default: 1, real time; with --lockstep 0, the clients set the pace)")
    p.add_argument("--lockstep", action="store_true",
                   help="advance a tick only when every lockstep client asked for it")
    p.add_argument("--pipelined", action="store_true",
                   help="lockstep: send each round before stepping and compute the next one "
                        "while the clients work (commands act one tick later)")
    p.add_argument("--lockstep-clients", type=int, default=1, metavar="N",
                   help="in lockstep, do not start before N participants connected")
    p.add_argument("--lockstep-timeout", type=float, default=30.0, metavar="S",
                   help="demote a participant that holds the clock longer (0 = never)")
    p.add_argument("--paused", action="store_true",
                   help="start paused (rounds are still served; simulation CMD PAUSE resumes)")
    p.add_argument("--allow-world-control", action="store_true",
                   help="let network clients pause, reset and move bodies through "
                        "simulation:0 (reading poses is always allowed)")
    p.add_argument("--watchdog", type=float, default=2.0, metavar="S",
                   help="stop a robot whose driving client has been silent for S simulated "
                        "seconds (default %(default)s; 0 = off)")
    p.add_argument("--max-connections", type=int, default=None, metavar="N",
                   help="connections open at once over all ports (default: 4 per robot or "
                        "camera port, at least 64)")
    p.add_argument("--output-limit", type=float, default=32.0, metavar="MIB",
                   help="disconnect a client with more than this many MiB of output waiting "
                        "unread (default %(default)s; 0 = no limit)")
    p.add_argument("--frame-timeout", type=float, default=10.0, metavar="S",
                   help="disconnect a client that leaves a message incomplete for S seconds "
                        "(default %(default)s; 0 = never)")
    p.add_argument("--seed", type=int, default=None, help="simulation seed (default: world's)")
    p.add_argument("--fidelity", choices=("fast", "render"), default=None,
                   help="sensing: fast (2-D ray casts, geometric blobs) or render (PyBullet "
                        "rays, rendered images); default: the world's")
    p.add_argument("--quit-time", type=float, default=None, metavar="S",
                   help="stop at this simulation time (default: the world's; 0 = never)")
    p.add_argument("--ports-json", metavar="FILE", default=None,
                   help="also write the robot / port / devices table to FILE as JSON once "
                        "every port is bound")
    p.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    return p


def _check_options(p: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse option values that make no sense, naming the option (no traceback)."""
    for name, value, ok, expected in (
        ("--speedup", args.speedup, args.speedup is None or args.speedup >= 0, "a number >= 0"),
        ("--watchdog", args.watchdog, args.watchdog >= 0, "seconds >= 0"),
        ("--max-connections", args.max_connections,
         args.max_connections is None or args.max_connections >= 1,
         "an integer >= 1"),
        ("--output-limit", args.output_limit, args.output_limit >= 0, "MiB >= 0"),
        ("--frame-timeout", args.frame_timeout, args.frame_timeout >= 0, "seconds >= 0"),
        ("--lockstep-timeout", args.lockstep_timeout, args.lockstep_timeout >= 0,
         "seconds >= 0"),
    ):
        if not ok or (isinstance(value, float) and value != value):
            p.error(f"{name}: expected {expected}, got {value}")


def default_speedup(speedup: float | None, lockstep: bool) -> float:
    """Real time unless told otherwise; in lockstep the clients set the pace."""
    if speedup is not None:
        return speedup
    return 0.0 if lockstep else 1.0


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _check_options(parser, args)
    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if args.replay is not None or args.world is None:
        if args.world is not None or args.replay is None:
            print("player-server: give a WORLD or --replay RUN.mcap (one of them)",
                  file=sys.stderr)
            return 2
        from player_server.replay.serve import main as replay_main

        return replay_main(args)
    from player_server.sim import Simulation
    from worlds import WorldError, load_world, world_path

    path = Path(args.world)
    stage = None
    try:
        if is_stage_source(args.world):
            stage, plan = load_stage_source(args.world, args.port)
            world = stage.spec
        else:
            world = load_world(path if path.suffix == ".toml" or path.exists() else
                               world_path(args.world))
    except (WorldError, OSError, KeyError) as exc:
        print(f"player-server: {exc}", file=sys.stderr)
        return 2
    sim = Simulation(world, seed=args.seed, fidelity=args.fidelity)
    if stage is not None:
        sim.set_paused(args.paused or stage.paused)
        endpoints = plan_endpoints(plan, stage, sim,
                                   allow_world_control=args.allow_world_control,
                                   ephemeral=args.port == 0)
    else:
        sim.set_paused(args.paused)
        endpoints = world_endpoints(world, sim, args.port,
                                    allow_world_control=args.allow_world_control)
    server = PlayerServer(
        sim, endpoints,
        interval_s=sim.interval_s,
        clock=time.monotonic,
        host=args.host,
        speedup=default_speedup(args.speedup, args.lockstep),
        config=CoreConfig(lockstep=args.lockstep, lockstep_clients=args.lockstep_clients,
                          lockstep_timeout_s=args.lockstep_timeout,
                          pipelined=args.pipelined, watchdog_s=args.watchdog,
                          max_connections=args.max_connections,
                          output_limit_bytes=int(args.output_limit * (1 << 20)),
                          frame_timeout_s=args.frame_timeout),
        quit_time_s=world.sim.quit_time_s if args.quit_time is None else args.quit_time,
    )
    try:
        server.start()
    except OSError as exc:
        from player_server.server.listen_errors import describe_listen_error

        ports = [e.requested_port for e in endpoints]
        print(f"player-server: {describe_listen_error(exc, args.host, ports)}", file=sys.stderr)
        sim.close()
        return 1
    mode = ("pipelined lockstep" if args.pipelined else "lockstep") if args.lockstep \
        else f"speedup {server.speedup:g}"
    if args.allow_world_control:
        mode += ", world control allowed"
    if args.ports_json:  # before the table: a script that read the table finds the file
        write_atomically(Path(args.ports_json), table_json(
            endpoints, plan.ports() if stage is not None else None))
    print(f"world {world.name!r} ({world.source}), {mode}", flush=True)
    print(server.table(), flush=True)

    try:
        return serve_until_done(server)
    finally:
        sim.close()


if __name__ == "__main__":
    sys.exit(main())
