"""``player-server WORLD.toml``: serve every robot of a world over the Player protocol."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from pathlib import Path

from player_server.protocol.constants import DEFAULT_PORT
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="player-server", add_help=False,
        description="Serve the robots of a world over the Player 3.x protocol "
                    "(one port per robot, starting at the base port).")
    p.add_argument("--help", action="help", help="show this help and exit")
    p.add_argument("world", help="world file (.toml) or the name of a bundled world")
    p.add_argument("-p", "--port", type=int, default=DEFAULT_PORT,
                   help="base port (default %(default)s; 0 = ephemeral ports)")
    p.add_argument("-h", "--host", default="127.0.0.1",
                   help="address to bind (default %(default)s)")
    p.add_argument("--speedup", type=float, default=None,
                   help="simulated seconds per wall second, 0 = as fast as possible "
                        "(default: the world's)")
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
    p.add_argument("--seed", type=int, default=None, help="simulation seed (default: world's)")
    p.add_argument("--fidelity", choices=("fast", "render"), default=None,
                   help="sensing: fast (2-D ray casts, geometric blobs) or render (PyBullet "
                        "rays, rendered images); default: the world's")
    p.add_argument("--quit-time", type=float, default=None, metavar="S",
                   help="stop at this simulation time (default: the world's; 0 = never)")
    p.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    from player_server.sim import Simulation
    from worlds import WorldError, load_world, world_path

    path = Path(args.world)
    try:
        world = load_world(path if path.suffix == ".toml" or path.exists() else
                           world_path(args.world))
    except (WorldError, OSError, KeyError) as exc:
        print(f"player-server: {exc}", file=sys.stderr)
        return 2
    sim = Simulation(world, seed=args.seed, fidelity=args.fidelity)
    sim.set_paused(args.paused)
    endpoints = world_endpoints(world, sim, args.port)
    server = PlayerServer(
        sim, endpoints,
        interval_s=sim.interval_s,
        clock=time.monotonic,
        host=args.host,
        speedup=world.sim.speedup if args.speedup is None else args.speedup,
        config=CoreConfig(lockstep=args.lockstep, lockstep_clients=args.lockstep_clients,
                          lockstep_timeout_s=args.lockstep_timeout,
                          pipelined=args.pipelined),
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
    print(f"world {world.name!r} ({world.source}), {mode}", flush=True)
    print(server.table(), flush=True)

    def _stop(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _stop)
    code = 0
    try:
        while not server.finished.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        try:
            server.stop()
        except RuntimeError as exc:
            print(f"player-server: {exc}: {exc.__cause__}", file=sys.stderr)
            code = 1
        sim.close()
    return code


if __name__ == "__main__":
    sys.exit(main())
