"""Real-time factor of the long-term experiment.

    python bench/longterm_rtf.py [--sim-hours 3] [--keep] [--no-pin-cpus] [--no-record]
                                 [--allocator murdoch|cbba|cbga] [--group-tasks RATE]

Runs `murdoch run longterm --sim-hours H --speedup 0` into a temporary directory, prints the
resident memory of every process at the start and at the end of the run, and as its last line
`sim_hours=H wall_s=<x> rtf=<y> tasks_completed=<n> charge_trips=<c> mcap_mib=<m>`
(the size of the run's run.mcap; `--no-record` runs without it, the baseline of what
recording costs; `--allocator` and `--group-tasks` are passed to the run, for the wall time
of a 3-hour run per allocator).
Target on a 2-core machine: 3 simulated hours in at most 5 minutes (rtf >= 36).

Before it, the CPU time of the whole run (the runner with its serving thread, the
recording's writer process and every robot process) per simulated second, and the real-time
factor that CPU time would allow if the machine's cores were kept busy all the time
(``cpu_bound_rtf``): the gap between the two is time lost waiting along the lockstep chain.
``cpu_steal`` is the share of the machine's CPU time the hypervisor gave to others during
the run (from /proc/stat): on a shared host it slows the whole run, and runs with different
steal are not comparable.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def cpu_ticks() -> tuple[int, int]:
    """(all, steal) jiffies of the whole machine from /proc/stat (zeros where it is not
    there). Steal is time the hypervisor gave this machine's CPUs to someone else: on a
    shared host it slows every process of the run alike."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()[1:]
    except OSError:
        return 0, 0
    values = [int(v) for v in fields]
    return sum(values[:8]), values[7] if len(values) > 7 else 0


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--sim-hours", type=float, default=3.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--keep", action="store_true", help="keep the run directory")
    p.add_argument("--robot-nice", type=int, default=None,
                   help="niceness of the robot processes (default: murdoch run's)")
    p.add_argument("--no-pin-cpus", action="store_true",
                   help="let the serving thread share its CPU (murdoch run --no-pin-cpus)")
    p.add_argument("--no-record", action="store_true",
                   help="write no run.mcap (murdoch run --no-record)")
    p.add_argument("--allocator", default=None, help="murdoch run --allocator")
    p.add_argument("--group-tasks", type=float, default=None, help="murdoch run --group-tasks")
    args = p.parse_args()
    out = Path(tempfile.mkdtemp(prefix="bench-longterm-"))
    murdoch = Path(sys.executable).parent / "murdoch"
    cmd = [str(murdoch), "run", "longterm", "--sim-hours", str(args.sim_hours), "--speedup", "0",
           "--seed", str(args.seed), "--out", str(out), "--no-replay"]
    if args.robot_nice is not None:
        cmd += ["--robot-nice", str(args.robot_nice)]
    if args.no_pin_cpus:
        cmd.append("--no-pin-cpus")
    if args.no_record:
        cmd.append("--no-record")
    if args.allocator:
        cmd += ["--allocator", args.allocator]
    if args.group_tasks is not None:
        cmd += ["--group-tasks", str(args.group_tasks)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    ticks0 = cpu_ticks()
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, check=False)
    ticks1 = cpu_ticks()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    steal = (ticks1[1] - ticks0[1]) / max(ticks1[0] - ticks0[0], 1)
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    try:
        (run,) = out.iterdir()
        s = json.loads((run / "summary.json").read_text())
        recording = run / "run.mcap"
        mcap_mib = recording.stat().st_size / 2**20 if recording.is_file() else 0.0
        for name, mem in s["processes"].items():
            print(f"memory {name}: start {mem['rss_first_bytes'] / 2**20:.1f} MiB, "
                  f"end {mem['rss_last_bytes'] / 2**20:.1f} MiB, "
                  f"peak {mem['peak_rss_bytes'] / 2**20:.1f} MiB")
        cores = os.cpu_count() or 1
        per_sim_s = cpu_s / max(s["sim_time_s"], 1e-9)
        print(f"cpu_s={cpu_s:.1f} cpu_ms_per_sim_s={1e3 * per_sim_s:.1f} "
              f"cores_busy={cpu_s / max(s['wall_time_s'], 1e-9):.2f} "
              f"cpu_bound_rtf={cores / max(per_sim_s, 1e-9):.1f} (on {cores} cores) "
              f"cpu_steal={100 * steal:.0f}%")
        print(f"allocator={s.get('allocator', 'murdoch')} "
              f"sim_hours={s['sim_time_s'] / 3600:g} wall_s={s['wall_time_s']:.1f} "
              f"rtf={s['real_time_factor']:.1f} tasks_completed={s['tasks']['executed']} "
              f"charge_trips={s['charging_trips']} mcap_mib={mcap_mib:.2f}")
    finally:
        if args.keep:
            print(f"run directory kept: {out}", file=sys.stderr)
        else:
            shutil.rmtree(out, ignore_errors=True)
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main())
