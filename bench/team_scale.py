"""A big team's run: real-time factor, start-up, memory and CPU per robot.

    python bench/team_scale.py [--world swarm100] [--until 10m] [--runs 3]
                               [--robots-per-process auto,10] [--seed 1]
    python bench/team_scale.py --existing RUN_DIR ...

Runs `murdoch run longterm --world W --until T --speedup 0 --no-replay
--robots-per-process K` (lockstep; K `auto` by default: for swarm100 on two CPUs a host of
100 robots and one of 1) into a temporary directory and reads what the run left:
`summary.json` (its real-time factor, start-up included) and `processes.jsonl` (the runner
samples every process's resident memory and CPU time about every two wall seconds).
Per run it prints:

- ``rtf``: the run's own real-time factor (simulated time over the whole wall time);
- ``startup_s``: wall seconds until simulated time first advanced (the robot processes start,
  import, connect and subscribe);
- ``steady_rtf``: simulated over wall time between the first and the last sample taken after
  the start (what a longer run tends to);
- ``rss_mib_per_robot``: the peak resident memory of every robot-carrying process, summed,
  over the number of team members (the robots and the overhead camera's desk);
- ``robot_cpu_us_per_tick``: CPU time of the robot-carrying processes between the first and
  the last sample after the start, per robot and per tick; ``runner_cpu_ms_per_tick`` the same
  for the runner (the simulator, its serving thread and the run loop).

With several values of ``--robots-per-process`` the values take turns within each round, so a
busy machine loads them alike; the last lines give the medians per value and their ratios to
the first. The last line is
``team members=<n> k=<k> rtf_median=<x> steady_rtf_median=<y> startup_s_median=<s>
rss_mib_per_robot=<m> robot_cpu_us_per_tick=<c>`` for the last value.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

BIN = Path(sys.executable).parent


@dataclass(frozen=True)
class TeamRun:
    members: int
    rtf: float
    startup_s: float
    steady_rtf: float
    rss_mib_per_robot: float
    robot_cpu_us_per_tick: float
    runner_cpu_ms_per_tick: float


def _samples(run_dir: Path) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    with (run_dir / "processes.jsonl").open(encoding="utf-8") as f:
        for line in f:
            rec = json.loads(line)
            if rec.get("kind") == "process":
                out.append(rec)
    return out


def measure(run_dir: Path, interval_s: float) -> TeamRun:
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    # every team member (robot or the overhead camera's desk) writes its own events file,
    # however many of them share a process
    robots = len(list((run_dir / "logs").glob("*.events.jsonl")))
    per_name: dict[str, list[dict[str, Any]]] = {}
    for rec in _samples(run_dir):
        per_name.setdefault(str(rec["name"]), []).append(rec)
    moving = sorted((float(r["t"]), float(r["wall_s"]))
                    for recs in per_name.values() for r in recs if float(r["t"]) > 0.0)
    if len(moving) < 2 or moving[-1][0] <= moving[0][0]:
        raise SystemExit(f"{run_dir}: too few samples after the start to measure (run longer)")
    (t0, w0), (t1, w1) = moving[0], moving[-1]
    steady = (t1 - t0) / max(w1 - w0, 1e-9)

    def cpu_per_sim_s(recs: list[dict[str, Any]]) -> float:
        """CPU seconds per simulated second of one process, over its samples after the
        start (0 with fewer than two)."""
        after = [r for r in recs if float(r["t"]) > 0.0]
        if len(after) < 2 or float(after[-1]["t"]) <= float(after[0]["t"]):
            return 0.0
        d_cpu = float(after[-1].get("cpu_s") or 0.0) - float(after[0].get("cpu_s") or 0.0)
        return d_cpu / (float(after[-1]["t"]) - float(after[0]["t"]))

    robot_rate = sum(cpu_per_sim_s(recs) for name, recs in per_name.items() if name != "runner")
    runner_rate = cpu_per_sim_s(per_name.get("runner", []))
    peak = sum(max(float(r.get("peak_rss_bytes") or 0) for r in recs)
               for name, recs in per_name.items() if name != "runner")
    return TeamRun(
        members=robots,
        rtf=float(summary["real_time_factor"]),
        startup_s=max(0.0, w0 - t0 / steady),
        steady_rtf=steady,
        rss_mib_per_robot=peak / max(robots, 1) / (1 << 20),
        robot_cpu_us_per_tick=1e6 * robot_rate * interval_s / max(robots, 1),
        runner_cpu_ms_per_tick=1e3 * runner_rate * interval_s,
    )


def one_run(args: argparse.Namespace, k: str, root: Path, n: int) -> TeamRun:
    out = root / f"k{k}-{n}"
    cmd = [str(BIN / "murdoch"), "run", "longterm", "--world", args.world, "--until",
           args.until, "--seed", str(args.seed), "--speedup", "0", "--no-replay",
           "--out", str(out), "--robots-per-process", str(k)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout,
                          stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        raise SystemExit(f"run failed ({proc.returncode}): {' '.join(cmd)}\n"
                         f"{proc.stderr[-3000:]}")
    (run_dir,) = [p for p in out.iterdir() if p.is_dir()]
    return measure(run_dir, args.interval)


def _fmt(r: TeamRun) -> str:
    return (f"members={r.members} rtf={r.rtf:.2f} startup_s={r.startup_s:.1f} "
            f"steady_rtf={r.steady_rtf:.2f} rss_mib_per_robot={r.rss_mib_per_robot:.1f} "
            f"robot_cpu_us_per_tick={r.robot_cpu_us_per_tick:.0f} "
            f"runner_cpu_ms_per_tick={r.runner_cpu_ms_per_tick:.1f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--world", default="swarm100")
    p.add_argument("--until", default="10m")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--robots-per-process", default="auto",
                   help="comma-separated values (whole numbers or auto), taking turns within "
                        "each round")
    p.add_argument("--interval", type=float, default=0.1, help="the world's tick (s)")
    p.add_argument("--timeout", type=float, default=7200.0, help="wall seconds per run")
    p.add_argument("--existing", nargs="*", default=None, metavar="RUN_DIR",
                   help="report runs already made instead")
    args = p.parse_args()
    if args.existing is not None:
        for d in args.existing:
            print(f"{d}: {_fmt(measure(Path(d), args.interval))}")
        return
    ks = [x.strip() for x in args.robots_per_process.split(",")]
    results: dict[str, list[TeamRun]] = {k: [] for k in ks}
    with tempfile.TemporaryDirectory(prefix="team-scale-") as tmp:
        for n in range(args.runs):
            for k in ks:
                load = os.getloadavg()[0]
                r = one_run(args, k, Path(tmp), n)
                results[k].append(r)
                print(f"run {n} k={k} load={load:.1f}: {_fmt(r)}", flush=True)
    med: dict[str, dict[str, float]] = {}
    for k in ks:
        rs = results[k]
        med[k] = {f: statistics.median(getattr(r, f) for r in rs)
                  for f in ("rtf", "steady_rtf", "startup_s", "rss_mib_per_robot",
                            "robot_cpu_us_per_tick", "runner_cpu_ms_per_tick")}
    base = med[ks[0]]
    for k in ks[1:]:
        ratios = " ".join(f"{f}={med[k][f] / base[f]:.2f}" for f in base if base[f])
        print(f"ratio k={k} / k={ks[0]}: {ratios}")
    for k in ks:
        m = med[k]
        print(f"team members={results[k][0].members} k={k} rtf_median={m['rtf']:.2f} "
              f"steady_rtf_median={m['steady_rtf']:.2f} startup_s_median={m['startup_s']:.1f} "
              f"rss_mib_per_robot={m['rss_mib_per_robot']:.1f} "
              f"robot_cpu_us_per_tick={m['robot_cpu_us_per_tick']:.0f} "
              f"runner_cpu_ms_per_tick={m['runner_cpu_ms_per_tick']:.1f}")


if __name__ == "__main__":
    main()
