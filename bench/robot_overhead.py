"""CPU time per tick of one robot process running a three-behaviour task.

Starts `player-server` (world `longterm`, lockstep, speedup 0, 10 Hz sensing) and one
`murdoch-robot` process for robot p1 (position2d, sonar, laser, blobfinder, power: the
longterm experiment's robots) running `object-tracking` (avoid-obstacles +
keep-distance-to-colour + wander, one thread each) for a fixed number of ticks, and takes
the robot process's CPU time (user + system) from the kernel when it exits, less what it had
used when it reported ready (/proc). Two tick counts are run so that what is left of
start-up and the shutdown cancel: per tick = (cpu(long) - cpu(short)) / (ticks(long) -
ticks(short)); 2000 ticks apart by default, so that a busy machine's noise stays small.

Prints one line per run and, last, `robot_cpu_us_per_tick_median=<x>`.

With `--allocator murdoch,cbba,cbga` it measures instead the robot processes of whole team
runs under each allocator: `murdoch run longterm --allocator A --until 20m --seed 1` (lockstep,
no recording, a process per robot), the allocators taken in turn within each round so that a
busy machine loads them alike. The runner samples each process's CPU time (processes.jsonl,
`cpu_s`, about every two wall seconds); a robot's CPU per tick is the CPU it used between
the first sample after `--from` simulated seconds (start-up and the first tasks left out)
and the last sample, divided by the ticks in between. Per run, the median over the six
mobile robots (the overhead camera's desk apart); printed: the median over runs per
allocator and its ratio to MURDOCH's.
`--existing RUN_DIR ...` reports the same figures from runs already made.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

BIN = Path(sys.executable).parent
TARGET_US = 300.0
WORLD = "longterm"
ROBOT = "p1"


def start_server(world: str) -> tuple[subprocess.Popen[str], int]:
    proc = subprocess.Popen(
        [str(BIN / "player-server"), world, "-p", "0", "--lockstep", "--speedup", "0",
         "--seed", "1", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    assert proc.stdout is not None
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        parts = line.split()
        if parts and parts[0] == ROBOT and parts[1].isdigit():
            return proc, int(parts[1])
    proc.kill()
    raise SystemExit(f"player-server did not report {ROBOT}'s port")


TASK = ("--task", "object-tracking", "--param", "colour=red", "--param", "duration_s=100000")


def cpu_so_far_s(pid: int) -> float:
    """CPU seconds a running process has used so far (all its threads; 0 without /proc)."""
    total_ns = 0
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return 0.0
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/schedstat", encoding="ascii") as f:
                total_ns += int(f.read().split()[0])
        except (OSError, ValueError, IndexError):
            continue  # a thread that just ended
    return total_ns / 1e9


def robot_cpu_s(port: int, ticks: int, task: bool = True) -> float:
    """Run one robot process for `ticks` ticks; return its CPU seconds (user + system)
    from the moment it reported ready (connected, subscribed, task accepted) to its exit.

    Start-up (interpreter, imports compiled from source, world file) costs about a third
    of a second with a spread of a tenth on a busy machine; leaving it out keeps that
    spread out of the per-tick figure.
    """
    proc = subprocess.Popen(
        [str(BIN / "murdoch-robot"), "-p", str(port), "--name", ROBOT, "--world", WORLD,
         *(TASK if task else ()), "--no-battery", "--max-ticks", str(ticks)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )
    assert proc.stderr is not None
    ready_at = 0.0
    for line in proc.stderr:
        if line.startswith('{"ready"'):
            ready_at = cpu_so_far_s(proc.pid)
            break
    # keep draining stderr (warnings) so the robot never blocks on a full pipe
    drain = threading.Thread(target=proc.stderr.read, daemon=True)
    drain.start()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    drain.join(5.0)
    proc.stderr.close()
    if proc.returncode != 0:
        raise SystemExit(f"murdoch-robot exited with {proc.returncode}")
    return usage.ru_utime + usage.ru_stime - ready_at


def team_run_cpu(allocator: str, until: str, from_s: float, out: Path) -> dict[str, float]:
    """One `murdoch run longterm` under `allocator`: CPU microseconds per tick of each robot
    process, from processes.jsonl."""
    proc = subprocess.run(
        [str(BIN / "murdoch"), "run", "longterm", "--allocator", allocator, "--until", until,
         "--seed", "1", "--no-record", "--no-replay", "--robots-per-process", "1",
         "--out", str(out)],
        capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"murdoch run --allocator {allocator} exited with "
                         f"{proc.returncode}: {proc.stderr[-500:]}")
    (run,) = out.iterdir()
    return run_cpu(run, from_s)


def run_cpu(run: Path, from_s: float) -> dict[str, float]:
    """CPU microseconds per tick of each robot process of a finished run (by robot name),
    between its first CPU sample at or after `from_s` simulated seconds and its last."""
    config = json.loads((run / "config.json").read_text())
    interval_s = 0.1
    samples: dict[str, list[tuple[float, float]]] = {}
    for line in (run / "processes.jsonl").read_text().splitlines():
        e = json.loads(line)
        name = str(e.get("name", ""))
        if e.get("kind") == "process" and "cpu_s" in e and name.startswith("robot-"):
            samples.setdefault(name[len("robot-"):], []).append((float(e["t"]),
                                                                 float(e["cpu_s"])))
    out_us: dict[str, float] = {}
    for name, points in samples.items():
        later = [p for p in points if p[0] >= from_s]
        if len(later) < 2 or later[-1][0] <= later[0][0]:
            continue
        (t0, c0), (t1, c1) = later[0], later[-1]
        out_us[name] = (c1 - c0) / ((t1 - t0) / interval_s) * 1e6
    if not out_us:
        raise SystemExit(f"{run}: no CPU samples after {from_s} s "
                         f"(allocator {config.get('allocator', 'murdoch')})")
    return out_us


def _robot_median(cpu: dict[str, float]) -> tuple[float, list[float], dict[str, float]]:
    mobile = [us for robot, us in cpu.items() if robot.startswith("p")]
    others = {r: round(us, 1) for r, us in cpu.items() if not r.startswith("p")}
    return statistics.median(mobile or list(cpu.values())), mobile, others


def existing_runs_main(runs: list[Path], from_s: float) -> int:
    """The same figures from run directories already made (e.g. runs made side by side)."""
    per: dict[str, list[float]] = {}
    for run in runs:
        allocator = json.loads((run / "config.json").read_text()).get("allocator", "murdoch")
        value, mobile, others = _robot_median(run_cpu(run, from_s))
        per.setdefault(allocator, []).append(value)
        print(f"{run}: {allocator} robot median {value:.1f} us/tick (robots "
              f"{sorted(round(v) for v in mobile)}, others {others})")
    names = list(per)
    base = statistics.median(per.get("murdoch", per[names[0]]))
    for name in names:
        median = statistics.median(per[name])
        print(f"robot_cpu_us_per_tick_median[{name}]={median:.1f} ratio_vs_murdoch="
              f"{median / base:.2f}")
    return 0


def allocators_main(args: argparse.Namespace) -> int:
    names = [a for a in args.allocator.split(",") if a]
    per: dict[str, list[float]] = {a: [] for a in names}
    with tempfile.TemporaryDirectory(prefix="robot-overhead-") as tmp:
        for run in range(args.runs):
            for name in names:
                cpu = team_run_cpu(name, args.until, args.from_s, Path(tmp) / f"{name}-{run}")
                value, mobile, others = _robot_median(cpu)
                per[name].append(value)
                print(f"run {run + 1} {name}: robot median {value:.1f} us/tick "
                      f"(robots {sorted(round(v) for v in mobile)}, others {others})", flush=True)
    base = statistics.median(per[names[0]])
    for name in names:
        median = statistics.median(per[name])
        print(f"robot_cpu_us_per_tick_median[{name}]={median:.1f} "
              f"ratio_vs_{names[0]}={median / base:.2f}")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--short", type=int, default=100, help="ticks of the short run")
    parser.add_argument("--long", type=int, default=2100, help="ticks of the long run")
    parser.add_argument("--allocator", default="",
                        help="comma-separated allocators: measure whole team runs under each "
                             "(the first is the baseline of the ratios)")
    parser.add_argument("--until", default="20m", help="with --allocator: each run's length")
    parser.add_argument("--from", dest="from_s", type=float, default=120.0,
                        help="with --allocator: simulated seconds left out at the start")
    parser.add_argument("--existing", nargs="+", type=Path, default=(), metavar="RUN_DIR",
                        help="report the figures of run directories already made instead")
    args = parser.parse_args()
    if args.existing:
        return existing_runs_main(list(args.existing), args.from_s)
    if args.allocator:
        return allocators_main(args)
    server, port = start_server(WORLD)
    per_tick_us: list[float] = []
    idle_us: list[float] = []
    span = args.long - args.short
    try:
        for run in range(args.runs):
            short = robot_cpu_s(port, args.short)
            long = robot_cpu_s(port, args.long)
            us = (long - short) / span * 1e6
            per_tick_us.append(us)
            # The same robot with no task: reading a data round and sending a stop command.
            idle = (robot_cpu_s(port, args.long, False) - robot_cpu_s(port, args.short, False))
            idle_us.append(idle / span * 1e6)
            print(f"run {run + 1}: short {short:.3f} s, long {long:.3f} s -> {us:.1f} us/tick "
                  f"(no task: {idle_us[-1]:.1f} us/tick)", flush=True)
    finally:
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()
    median = statistics.median(per_tick_us)
    idle_median = statistics.median(idle_us)
    print(f"no task (Player I/O and snapshots only): {idle_median:.1f} us/tick; "
          f"behaviour threads, arbitration and task: {median - idle_median:.1f} us/tick")
    print(f"target <= {TARGET_US:.0f} us/tick; ratio {median / TARGET_US:.2f}")
    print(f"robot_cpu_us_per_tick_median={median:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
