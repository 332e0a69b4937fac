"""What recording run.mcap costs, measured apart from the robots and the network.

    python bench/recording_cost.py [--sim-minutes 10] [--reps 2] [--rate 2]

Steps the `longterm` world with every robot wandering and every device read each tick (as the
Player drivers of a run read them), alternately without and with `RunRecording.on_step`
after each step, and prints per simulated hour: the serving thread's CPU time (the thread
every robot waits on in a run), the CPU time of the writer process (which builds, encodes
and writes the messages) and the recording's size. Medians over `--reps` alternating pairs;
CPU time, not wall time, so that other work on a shared machine disturbs it less. Last line:
`serving_s_per_sim_h_off=<a> on=<b> writer_cpu_s_per_sim_h=<c> mcap_mib_per_sim_h=<d>`.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from experiments.recording import RunRecording
from player_server.sim import Simulation
from player_server.sim.demo import WanderDriver
from worlds import load_world, world_path


def children_cpu_s() -> float:
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def one(spec: object, ticks: int, out: Path | None, rate: float) -> tuple[float, float, int]:
    """(serving thread CPU s, writer process CPU s, bytes recorded)"""
    sim = Simulation(spec, seed=1)
    try:
        wd = WanderDriver(sim, np.random.default_rng(1), sense_all=True)
        readers = {r.name: [getattr(sim, dev) for dev in ("laser", "sonar", "blobs", "power")
                            if getattr(r.devices, "blobfinder" if dev == "blobs" else dev)
                            is not None] + [sim.odometry] for r in spec.robots}
        w0 = children_cpu_s()
        rec = RunRecording(out, spec, rate_hz=rate) if out else None
        t0 = time.thread_time()
        names = [r.name for r in spec.robots if r.devices.position2d is not None]
        for _ in range(ticks):
            wd.tick()
            for name in names:  # what the Player drivers read of every robot after a step
                for read in readers[name]:
                    read(name)
            if rec is not None:
                rec.on_step(sim, sim.time_s)
        serving = time.thread_time() - t0
        if rec is not None:
            rec.close()  # (waits for the writer process, whose CPU time is then counted)
        return serving, children_cpu_s() - w0, out.stat().st_size if out else 0
    finally:
        sim.close()


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--sim-minutes", type=float, default=10.0)
    p.add_argument("--reps", type=int, default=2)
    p.add_argument("--rate", type=float, default=2.0)
    args = p.parse_args()
    spec = load_world(world_path("longterm"))
    ticks = round(args.sim_minutes * 60 / spec.sim.interval_sim_s)
    per_h = 60.0 / args.sim_minutes
    off_s, on_s, writer, sizes = [], [], [], []
    one(spec, 50, None, args.rate)  # compile the sensing kernels first
    with tempfile.TemporaryDirectory(prefix="bench-recording-") as tmp:
        for k in range(args.reps):
            s, _, _ = one(spec, ticks, None, args.rate)
            off_s.append(s * per_h)
            s, w, size = one(spec, ticks, Path(tmp) / f"{k}.mcap", args.rate)
            on_s.append(s * per_h)
            writer.append(w * per_h)
            sizes.append(size / 2**20 * per_h)
            print(f"pair {k + 1}: serving thread off {off_s[-1]:.2f} on {on_s[-1]:.2f} "
                  f"s/sim-h; writer process {writer[-1]:.2f} s/sim-h; "
                  f"{sizes[-1]:.2f} MiB/sim-h", flush=True)
    med = statistics.median
    print(f"serving_s_per_sim_h_off={med(off_s):.2f} on={med(on_s):.2f} "
          f"writer_cpu_s_per_sim_h={med(writer):.2f} mcap_mib_per_sim_h={med(sizes):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
