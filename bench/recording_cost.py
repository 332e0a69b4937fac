"""What recording run.mcap costs, measured apart from the robots and the network.

    python bench/recording_cost.py [--sim-minutes 10] [--reps 2] [--rate 2]

Steps the `longterm` world with every robot wandering and every device read each tick (as the
Player drivers of a run read them), alternately without and with `RunRecording.on_step`
after each step, and prints per simulated hour: the serving thread's CPU time (the thread
every robot waits on in a run), the whole process's CPU time (the writer thread included),
and the recording's size. Medians over `--reps` alternating pairs; CPU time, not wall time,
so that other work on a shared machine disturbs it less. Last line:
`serving_s_per_sim_h_off=<a> on=<b> writer_cpu_s_per_sim_h=<c> mcap_mib_per_sim_h=<d>`.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from experiments.recording import RunRecording
from player_server.sim import Simulation
from player_server.sim.demo import WanderDriver
from worlds import load_world, world_path


def one(spec: object, ticks: int, out: Path | None, rate: float) -> tuple[float, float, int]:
    sim = Simulation(spec, seed=1)
    try:
        wd = WanderDriver(sim, np.random.default_rng(1), sense_all=True)
        readers = {r.name: [getattr(sim, dev) for dev in ("laser", "sonar", "blobs", "power")
                            if getattr(r.devices, "blobfinder" if dev == "blobs" else dev)
                            is not None] + [sim.odometry] for r in spec.robots}
        rec = RunRecording(out, spec, rate_hz=rate, clock=time.monotonic) if out else None
        t0, p0 = time.thread_time(), time.process_time()
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
            rec.close()
        total = time.process_time() - p0
        return serving, total, out.stat().st_size if out else 0
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
    off_s, on_s, off_cpu, on_cpu, sizes = [], [], [], [], []
    one(spec, 50, None, args.rate)  # compile the sensing kernels first
    with tempfile.TemporaryDirectory(prefix="bench-recording-") as tmp:
        for k in range(args.reps):
            s, c, _ = one(spec, ticks, None, args.rate)
            off_s.append(s * per_h)
            off_cpu.append(c * per_h)
            s, c, size = one(spec, ticks, Path(tmp) / f"{k}.mcap", args.rate)
            on_s.append(s * per_h)
            on_cpu.append(c * per_h)
            sizes.append(size / 2**20 * per_h)
            print(f"pair {k + 1}: serving thread off {off_s[-1]:.2f} on {on_s[-1]:.2f} "
                  f"s/sim-h; process CPU off {off_cpu[-1]:.2f} on {on_cpu[-1]:.2f} s/sim-h; "
                  f"{sizes[-1]:.2f} MiB/sim-h", flush=True)
    med = statistics.median
    print(f"serving_s_per_sim_h_off={med(off_s):.2f} on={med(on_s):.2f} "
          f"writer_cpu_s_per_sim_h={(med(on_cpu) - med(off_cpu)) - (med(on_s) - med(off_s)):.2f} "
          f"mcap_mib_per_sim_h={med(sizes):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
