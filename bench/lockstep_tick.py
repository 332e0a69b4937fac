"""Wall time of one lockstep tick of the ``longterm`` world with 7 lockstep clients.

Runs the Player server in this process (its serving thread, as ``player-server
longterm --lockstep --speedup 0`` would) and starts 7 client processes: one per robot
(6 participants, each subscribing to every device of its port, declining the DATA of
the camera and the fiducial detector as a robot process does, and
reading one PULL round and sending one velocity command per tick, like a robot
controller) and one for the overhead camera (the same devices, with the
``lockstep`` property set so that it holds the clock too). A tick is the wall time
between two successive rounds published: the simulation step plus the rounds of all 7
clients. Also reported per tick: the share spent in ``Simulation.step`` (physics and the
sim's own bookkeeping), in the drivers producing data (sensing), in encoding and queuing
rounds, and the server thread's CPU time. ``--profile`` adds a cProfile of the serving
thread.

The last line reads ``lockstep_tick_ms_median=<x>``.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import itertools
import os
import pstats
import statistics
import subprocess
import sys
import time
from typing import Any

WORLD = "longterm"
#: the whole tick must fit this at >= 36x real time with 0.1 s ticks
TARGET_MS = 2.8


def client_main(port: int, ticks: int, overhead: bool) -> int:
    """One client process: subscribe, then ``ticks`` rounds (velocity command each)."""
    from player_server.client import PROXIES, PlayerClient, Position2dProxy
    from player_server.protocol import constants as c
    from player_server.protocol.constants import MsgType, interface_name

    cl = PlayerClient("127.0.0.1", port, lockstep=True if overhead else None).connect()
    pos = None
    for addr in cl.devlist():
        name = interface_name(addr.interf)
        if addr.index != 0 or name not in PROXIES or name == "simulation":
            continue
        p = cl.subscribe(PROXIES[name], addr.index)
        if name in ("camera", "fiducial"):  # opened but declined, as a robot process does
            cl.set_replace_rule(c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE, addr.interf,
                                addr.index, int(MsgType.DATA))
        if isinstance(p, Position2dProxy):
            pos = p
    for i in range(ticks):
        cl.read()
        if pos is not None:
            pos.set_velocity(0.2 if i % 40 < 30 else 0.0, 0.3)
    cl.close()
    return 0


class _Timer:
    """Thread CPU time of wrapped calls made on the serving thread (CPU, not wall: the
    2-core machine is shared with the 7 clients, and a send may let one of them run)."""

    def __init__(self) -> None:
        self.wall: list[float] = []
        self.depth = 0

    def wrap(self, fn: Any) -> Any:
        def timed(*a: Any, **k: Any) -> Any:
            if self.depth:
                return fn(*a, **k)
            self.depth += 1
            t0 = time.thread_time()
            try:
                return fn(*a, **k)
            finally:
                self.wall.append(time.thread_time() - t0)
                self.depth -= 1
        return timed


#: the simulator's readers the drivers call (sensing is computed lazily inside them)
SIM_READERS = ("odometry", "sonar", "laser", "ranger", "blobs", "bumpers", "gripper", "ptz",
               "power", "overhead", "snapshot", "get_pose", "camera_image")


def run_once(ticks: int, warmup: int, profile: bool, pipelined: bool = False
             ) -> dict[str, float]:
    from player_server.server.assembly import world_endpoints
    from player_server.server.core import CoreConfig
    from player_server.server.runner import PlayerServer
    from player_server.sim import Simulation
    from worlds import load_world, world_path

    world = load_world(world_path(WORLD))
    sim = Simulation(world, seed=1)
    endpoints = world_endpoints(world, sim, 0)
    server = PlayerServer(sim, endpoints, interval_s=sim.interval_s, clock=time.monotonic,
                          speedup=0.0, config=CoreConfig(lockstep=True, lockstep_clients=7,
                                                         pipelined=pipelined))
    step_t, publish_t, data_t = _Timer(), _Timer(), _Timer()
    sim_step = sim.step
    sim.step = step_t.wrap(sim_step)  # type: ignore[method-assign]
    publish_marks: list[tuple[float, float]] = []
    core = server.core
    core_publish = core.publish

    def publish(*args: Any) -> None:
        publish_marks.append((time.perf_counter(), time.thread_time()))
        t0 = time.thread_time()
        core_publish(*args)
        publish_t.wall.append(time.thread_time() - t0)

    core.publish = publish  # type: ignore[method-assign]
    sense_t = _Timer()
    for name in SIM_READERS:
        if hasattr(sim, name):
            setattr(sim, name, sense_t.wrap(getattr(sim, name)))
    device_data = core._device_data
    core._device_data = data_t.wrap(device_data)  # type: ignore[method-assign]
    prof = cProfile.Profile(time.thread_time) if profile else None
    if prof is not None:
        loop = server._loop

        def profiled_loop() -> None:
            prof.enable()
            try:
                loop()
            finally:
                prof.disable()
        server._loop = profiled_loop  # type: ignore[method-assign]
    server.start()
    procs: list[subprocess.Popen[bytes]] = []
    total = ticks + warmup
    try:
        for ep in endpoints:
            procs.append(subprocess.Popen(
                [sys.executable, __file__, "--client", str(ep.port), "--ticks", str(total),
                 *(["--overhead"] if not ep.mobile else [])]))
        deadline = time.monotonic() + 60 + total * 0.1
        for p in procs:
            p.wait(max(1.0, deadline - time.monotonic()))
            if p.returncode != 0:
                raise SystemExit(f"a client exited with {p.returncode}")
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        server.stop()
        sim.close()
    marks = publish_marks[warmup:total]
    walls = [b[0] - a[0] for a, b in itertools.pairwise(marks)]
    cpus = [b[1] - a[1] for a, b in itertools.pairwise(marks)]
    steps = step_t.wall[warmup:total]
    n_dev = len(data_t.wall) / max(len(publish_t.wall), 1)
    n_pub = max(len(publish_t.wall), 1)
    out = {
        "sense_ms": sum(sense_t.wall) / n_pub * 1e3,
        "tick_ms": statistics.median(walls) * 1e3,
        "server_cpu_ms": statistics.median(cpus) * 1e3,
        "step_ms": statistics.median(steps) * 1e3,
        "publish_ms": statistics.median(publish_t.wall[warmup:total]) * 1e3,
        "device_data_ms": sum(data_t.wall) / n_pub * 1e3,
        "devices_per_tick": n_dev,
    }
    if prof is not None:
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats("tottime").print_stats(30)
        print(s.getvalue())
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--ticks", type=int, default=300, help="measured ticks per run")
    ap.add_argument("--warmup", type=int, default=30)
    ap.add_argument("--profile", action="store_true", help="cProfile the serving thread")
    ap.add_argument("--pipelined", action="store_true",
                    help="pipelined lockstep (the next round is prepared after the step; the "
                         "breakdown then counts that preparation under I/O)")
    ap.add_argument("--client", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--overhead", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.client is not None:
        return client_main(args.client, args.ticks, args.overhead)
    ticks: list[float] = []
    for run in range(args.runs):
        r = run_once(args.ticks, args.warmup, args.profile, args.pipelined)
        ticks.append(r["tick_ms"])
        cpu = r["server_cpu_ms"]
        sim_ms = r["step_ms"] + r["sense_ms"]
        print(f"run {run + 1}: tick {r['tick_ms']:.2f} ms wall; server thread CPU {cpu:.2f} ms"
              f" = sim step {r['step_ms']:.2f} + sim sensing {r['sense_ms']:.2f} "
              f"(sim {sim_ms / cpu:.0%} of the server's CPU) + drivers/encoding/queues "
              f"{r['device_data_ms'] - r['sense_ms']:.2f} (of publish {r['publish_ms']:.2f}, "
              f"{r['devices_per_tick']:.0f} device reads) + input and socket I/O "
              f"{cpu - r['step_ms'] - r['publish_ms']:.2f}; load average "
              f"{os.getloadavg()[0]:.1f}", flush=True)
    med = statistics.median(ticks)
    print(f"target <= {TARGET_MS} ms (36x real time, 0.1 s ticks); ratio {med / TARGET_MS:.2f}")
    print(f"lockstep_tick_ms_median={med:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
