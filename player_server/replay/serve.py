"""``player-server --replay RUN/run.mcap``: the recorded robots, one port per robot.

Recorded time runs at `--speedup` simulated seconds per wall second from the start of the
recording to its end, where the server stops. Each robot's port offers the devices recorded
for it (position2d with the recorded odometry, laser, sonar, power, blobfinder); commands are
taken and ignored.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time

from player_server.record.reader import RecordingError
from player_server.replay.drivers import replay_drivers
from player_server.replay.source import RecordedRun, ReplayClock
from player_server.server.core import CoreConfig
from player_server.server.endpoint import Endpoint
from player_server.server.runner import PlayerServer
from player_server.server.serve_loop import serve_until_done

log = logging.getLogger(__name__)


def build_server(run: RecordedRun, base_port: int, *, host: str = "127.0.0.1",
                 speedup: float = 1.0) -> PlayerServer:
    """A Player server over the recording (not started)."""
    endpoints = []
    for i, robot in enumerate(run.robots):
        try:
            drivers = replay_drivers(run, robot)
            mobile = bool(run.robots[robot].get("mobile", True))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise RecordingError(f"{run.path}: robot {robot!r} of the recorded world is not "
                                 f"usable: missing or malformed {exc}") from exc
        if drivers:
            endpoints.append(Endpoint(robot, drivers,
                                      requested_port=0 if base_port == 0 else base_port + i,
                                      mobile=mobile))
    if not endpoints:
        raise RecordingError(f"{run.path}: no robot has a recorded device to serve")
    return PlayerServer(ReplayClock(run), endpoints, interval_s=run.interval_s,
                        clock=time.monotonic, host=host, speedup=speedup,
                        config=CoreConfig(), quit_time_s=max(run.end_s, run.interval_s))


def main(args: argparse.Namespace) -> int:
    """Serve ``args.replay`` (uses args.port, args.host, args.speedup)."""
    speedup = 1.0 if args.speedup is None else float(args.speedup)
    if speedup < 0:
        print(f"player-server: --speedup must be >= 0, got {speedup:g}", file=sys.stderr)
        return 2
    try:
        run = RecordedRun(args.replay)
        server = build_server(run, args.port, host=args.host, speedup=speedup)
    except RecordingError as exc:
        print(f"player-server: {exc}", file=sys.stderr)
        return 2
    try:
        server.start()
    except OSError as exc:
        print(f"player-server: cannot listen: {exc}", file=sys.stderr)
        return 1
    state = "complete" if run.info.complete else "cut short"
    print(f"replaying {run.path} ({state}): world {run.world!r}, {run.start_s:.1f} s to "
          f"{run.end_s:.1f} s at speedup {speedup:g}; commands are ignored", flush=True)
    print(server.table(), flush=True)

    return serve_until_done(server, lambda: print(
        f"end of the recording at {server.sim.time_s:.1f} s", flush=True))
