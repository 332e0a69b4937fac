"""``python -m player_server.viz``: watch a world live in meshcat, robots wandering.

    python -m player_server.viz [--world longterm] [--sim-seconds 600] [--speedup 1]
                                [--web-port 0] [--seed 0]

Starts the loopback-only viewer, prints its URL, and steps the simulation with every robot
wandering (the simulator's demo driver); robots on a charging pad show as charging. Stops at
the end of the simulated time, on Ctrl-C or on SIGTERM, and takes its viewer process with it
(the viewer also exits by itself if this process is killed).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m player_server.viz", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--world", default="longterm", help="world name or .toml path")
    parser.add_argument("--sim-seconds", type=float, default=600.0)
    parser.add_argument("--speedup", type=float, default=1.0, help="0 = as fast as possible")
    parser.add_argument("--web-port", type=int, default=0, help="0 = any free port")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rate-hz", type=float, default=10.0, help="viewer updates per second")
    parser.add_argument("--lasers", action="store_true", help="draw the robots' laser rays")
    parser.add_argument("--trails", type=int, default=0, metavar="N",
                        help="draw each robot's last N positions as a trail (0 = none)")
    args = parser.parse_args(argv)

    from pathlib import Path

    import numpy as np

    from player_server.sim import Simulation
    from player_server.sim.demo import WanderDriver
    from player_server.sim.pacing import Pacer
    from player_server.viz.feed import LiveFeed
    from player_server.viz.live import LiveView
    from player_server.viz.scene import layout_from_world
    from player_server.viz.server import ViewerProcess, ZmqChannel
    from worlds import load_world, world_path

    world = Path(args.world)
    spec = load_world(world if world.suffix == ".toml" else world_path(args.world))
    sim = Simulation(spec, seed=args.seed)
    driver = WanderDriver(sim, np.random.default_rng(args.seed))
    layout = layout_from_world(spec)
    lasers = tuple(shape.robot for shape in layout.lasers) if args.lasers else ()
    powered = tuple(r.name for r in spec.robots if r.devices.power is not None)
    pacer = Pacer(sim.interval_s, args.speedup, time.monotonic, time.sleep)
    stop = threading.Event()
    # SIGTERM stops like Ctrl-C: the viewer process is stopped on the way out
    signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    with ViewerProcess(web_port=args.web_port) as viewer:
        channel = ZmqChannel(viewer.urls.zmq_url)
        view = LiveView(layout, channel, max_rate_hz=args.rate_hz, trail_points=args.trails,
                        lasers=args.lasers)
        # no team reports states here: a robot on a charging pad shows as charging
        feed = LiveFeed(view, wall_clock=time.monotonic, period_s=1.0 / args.rate_hz,
                        power_robots=powered, scan_robots=lasers, states_from_power=True)
        print(f"meshcat live view: {viewer.urls.web_url}", flush=True)
        view.start()
        try:
            while sim.time_s < args.sim_seconds and not stop.is_set():
                driver.tick()
                pacer.wait(sim.tick)
                feed.after_step(sim)
        except KeyboardInterrupt:
            pass
        finally:
            view.stop()
            channel.close()
            sim.close()
    print(f"stopped at simulated time {sim.time_s:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
