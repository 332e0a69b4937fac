"""Simulator speed: worlds/longterm.toml headless, every robot sensing every tick (10 Hz) and
wandering. Prints per-run real-time factors with a cost breakdown and the cost per robot per
tick (µs of wall and CPU time), and last a line ``sim_rtf_median=<x> sim_rtf_min=<y>
us_per_robot_tick=<z>``.

    .venv/bin/python bench/sim_speed.py                    # fast fidelity, 6 robots
    .venv/bin/python bench/sim_speed.py --fidelity render --sim-seconds 10
    .venv/bin/python bench/sim_speed.py --robots 50
    .venv/bin/python bench/sim_speed.py --robots 1000 --template p1   # all sonar + laser
    .venv/bin/python bench/sim_speed.py --robots 300 --baseline-src /path/to/old/checkout

``--template`` makes every robot a copy of one robot of the world (p1 of longterm has a
16-sonar ring, a 181-reading laser, a camera and a blobfinder). ``--baseline-src`` runs each
run twice in fresh processes, first with the simulator of another source tree (its
``player_server`` and ``worlds`` first on the import path) and then with this one, and prints
both medians and their ratio.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from player_server.sim import Simulation
from player_server.sim.demo import WanderDriver
from worlds import ArenaSpec, Pose, WorldSpec, load_world, world_path


def scaled_world(spec: WorldSpec, n_robots: int, template: str = "") -> WorldSpec:
    """The world with n robots (copies of its own, cycling, or all of the robot named
    ``template``) on a grid in a larger room."""
    side = math.ceil(math.sqrt(n_robots))
    spacing = 2.0
    size = max(spec.arena.size_x_m, side * spacing + 2.0)
    arena: ArenaSpec = dataclasses.replace(spec.arena, size_x_m=size, size_y_m=size,
                                           obstacles=())
    robots = []
    for i in range(n_robots):
        base = (next(r for r in spec.robots if r.name == template) if template
                else spec.robots[i % len(spec.robots)])
        x = -size / 2 + 1.0 + spacing * (i % side) + 0.5
        y = -size / 2 + 1.0 + spacing * (i // side) + 0.5
        robots.append(dataclasses.replace(base, name=f"{base.name}_{i}",
                                          pose=Pose(x, y, 0.3 * i)))
    return dataclasses.replace(spec, arena=arena, robots=tuple(robots))


def one_run(spec: WorldSpec, fidelity: str, ticks: int,
            seed: int) -> tuple[float, dict[str, float]]:
    sim = Simulation(spec, fidelity=fidelity, profile_clock=time.perf_counter)
    try:
        driver = WanderDriver(sim, np.random.default_rng(seed), sense_all=True)
        for _ in range(10):  # warm-up: first reads activate the sensors
            driver.tick()
        sim.timings = type(sim.timings)()
        start_tick = sim.tick
        t0 = time.perf_counter()
        c0 = time.process_time()
        for _ in range(ticks):
            driver.tick()
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
        sim_s = (sim.tick - start_tick) * sim.interval_s
        per_tick = {k.removesuffix("_s"): 1e3 * v / ticks
                    for k, v in sim.timings.as_dict().items()}
        per_tick["total"] = 1e3 * wall / ticks
        per_tick["cpu"] = 1e3 * cpu / ticks
        per_tick["cpu_rtf"] = sim_s / max(cpu, 1e-9)
        n = max(1, len(spec.robots))
        per_tick["us_robot_tick"] = 1e6 * wall / ticks / n
        per_tick["cpu_us_robot_tick"] = 1e6 * cpu / ticks / n
        return sim_s / wall, per_tick
    finally:
        sim.close()


def ticks_s(spec: WorldSpec) -> float:
    """Simulated milliseconds per tick."""
    return 1e3 * spec.sim.interval_sim_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="longterm")
    ap.add_argument("--fidelity", choices=["fast", "render"], default="fast")
    ap.add_argument("--robots", type=int, default=0, help="scale to this many robots")
    ap.add_argument("--template", default="", help="every robot a copy of this one")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sim-seconds", type=float, default=120.0)
    ap.add_argument("--baseline-src", default="",
                    help="a source tree whose simulator is measured alternately with this one")
    args = ap.parse_args()
    if args.baseline_src:
        compare(args)
        return
    spec = load_world(world_path(args.world))
    if args.robots:
        spec = scaled_world(spec, args.robots, args.template)
    ticks = round(args.sim_seconds / spec.sim.interval_sim_s)
    rtfs = []
    cpu_ms = []
    us = []
    cpu_us = []
    for run in range(args.runs):
        load = os.getloadavg()[0]
        rtf, per_tick = one_run(spec, args.fidelity, ticks, seed=run)
        rtfs.append(rtf)
        cpu_ms.append(per_tick["cpu"])
        us.append(per_tick["us_robot_tick"])
        cpu_us.append(per_tick["cpu_us_robot_tick"])
        parts = " ".join(f"{k}={v:.3f}" for k, v in per_tick.items())
        print(f"run {run}: {len(spec.robots)} robots {args.fidelity} load={load:.1f} "
              f"rtf={rtf:.1f} ms/tick (wall unless cpu): {parts}", flush=True)
    print(f"cpu ms/tick median={statistics.median(cpu_ms):.3f} min={min(cpu_ms):.3f} "
          f"(cpu_rtf median={ticks_s(spec) / statistics.median(cpu_ms):.1f}); "
          f"load average now {os.getloadavg()[0]:.1f}")
    print(f"sim_rtf_median={statistics.median(rtfs):.2f} sim_rtf_min={min(rtfs):.2f} "
          f"us_per_robot_tick={statistics.median(us):.1f} "
          f"cpu_us_per_robot_tick={statistics.median(cpu_us):.1f}")


_RESULT = re.compile(r"sim_rtf_median=([0-9.]+) .* us_per_robot_tick=([0-9.]+) "
                     r"cpu_us_per_robot_tick=([0-9.]+)")


def compare(args: argparse.Namespace) -> None:
    """Alternate single runs of the baseline tree and this one, each in a fresh process."""
    here = Path(__file__).resolve().parents[1]
    base_args = [sys.executable, str(Path(__file__).resolve()), "--world", args.world,
                 "--fidelity", args.fidelity, "--robots", str(args.robots), "--template",
                 args.template, "--runs", "1", "--sim-seconds", str(args.sim_seconds)]
    results: dict[str, list[tuple[float, float, float]]] = {"baseline": [], "new": []}
    for run in range(args.runs):
        for label, src in (("baseline", args.baseline_src), ("new", str(here))):
            env = dict(os.environ, PYTHONPATH=src)
            out = subprocess.run(base_args, env=env, capture_output=True, text=True,
                                 check=True, cwd=src).stdout
            m = _RESULT.search(out)
            if m is None:
                raise SystemExit(f"no result line from the {label} run:\n{out}")
            results[label].append((float(m.group(1)), float(m.group(2)), float(m.group(3))))
            print(f"run {run} {label}: rtf={m.group(1)} us_per_robot_tick={m.group(2)} "
                  f"cpu_us_per_robot_tick={m.group(3)}", flush=True)
    med = {k: tuple(statistics.median(row[i] for row in v) for i in range(3))
           for k, v in results.items()}
    b, n = med["baseline"], med["new"]
    print(f"baseline_rtf_median={b[0]:.2f} baseline_us_per_robot_tick={b[1]:.1f} "
          f"baseline_cpu_us_per_robot_tick={b[2]:.1f}")
    print(f"sim_rtf_median={n[0]:.2f} sim_rtf_min={min(r[0] for r in results['new']):.2f} "
          f"us_per_robot_tick={n[1]:.1f} cpu_us_per_robot_tick={n[2]:.1f}")
    print(f"speedup_median={n[0] / max(b[0], 1e-9):.2f} "
          f"cpu_speedup_median={b[2] / max(n[2], 1e-9):.2f}")


if __name__ == "__main__":
    main()
