"""Player client/server latency and throughput over loopback TCP.

Starts ``player-server`` (paused, so rounds measure the protocol path and not physics) on
the ``simple`` world in its own process, then measures with our client:

* req_rtt_us_median: position2d GET_GEOM request -> ACK round trip;
* pull_round_us_median: one PULL round (REQ DATA, ACK, 6 DATA, SYNCH) with position2d,
  sonar, laser, ranger, bumper and power subscribed;
* msgs_per_s: DATA messages received per second by back-to-back PULL rounds.

Each figure is the median over several runs (each run's own median for latencies).
The last line reads ``req_rtt_us_median=<x> pull_round_us_median=<y> msgs_per_s=<z>``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from player_server.client import (
    BumperProxy,
    LaserProxy,
    PlayerClient,
    Position2dProxy,
    PowerProxy,
    RangerProxy,
    SonarProxy,
)


def start_server(world: str, *mode: str) -> tuple[subprocess.Popen[str], int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "player_server.server", world, "-p", "0", "--speedup", "0",
         "-q", *(mode or ("--paused",))],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        parts = line.split()
        if len(parts) >= 3 and parts[1].isdigit() and parts[0] != "robot":
            return proc, int(parts[1])
    proc.kill()
    raise RuntimeError("the server did not print its port table")


def timed(fn: object, n: int) -> list[float]:
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()  # type: ignore[operator]
        out.append(time.perf_counter() - t0)
    return out


def lockstep_rounds(world: str, runs: int, n: int) -> float:
    """Median read() of a lockstep participant: includes stepping the simulation."""
    proc, port = start_server(world, "--lockstep")
    try:
        cl = PlayerClient("127.0.0.1", port).connect()
        for p in (Position2dProxy, SonarProxy, LaserProxy, RangerProxy, BumperProxy,
                  PowerProxy):
            cl.subscribe(p)
        for _ in range(20):
            cl.read()
        result = statistics.median(statistics.median(timed(cl.read, n)) for _ in range(runs))
        cl.close()
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    return result * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("-n", type=int, default=1000, help="operations per run")
    ap.add_argument("--world", default="simple")
    args = ap.parse_args()
    proc, port = start_server(args.world)
    try:
        cl = PlayerClient("127.0.0.1", port, lockstep=False).connect()
        proxies = [cl.subscribe(p) for p in (Position2dProxy, SonarProxy, LaserProxy,
                                               RangerProxy, BumperProxy, PowerProxy)]
        pos = proxies[0]
        for _ in range(200):
            cl.read()
            pos.get_geometry()
        req, pull, rate = [], [], []
        for run in range(args.runs):
            r = statistics.median(timed(pos.get_geometry, args.n)) * 1e6
            p = statistics.median(timed(cl.read, args.n)) * 1e6
            before = sum(x.data_count for x in proxies)
            t0 = time.perf_counter()
            while time.perf_counter() - t0 < 1.0:
                cl.read()
            msgs = (sum(x.data_count for x in proxies) - before) / (time.perf_counter() - t0)
            req.append(r)
            pull.append(p)
            rate.append(msgs)
            print(f"run {run + 1}: req_rtt {r:.1f} us, pull_round {p:.1f} us, "
                  f"{msgs:.0f} DATA msgs/s", flush=True)
        cl.close()
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    lockstep = lockstep_rounds(args.world, args.runs, max(args.n // 4, 50))
    print(f"for information: a lockstep tick (physics step + round, one robot process) "
          f"takes {lockstep:.1f} us median")
    r, p, m = statistics.median(req), statistics.median(pull), statistics.median(rate)
    print(f"targets: req_rtt <= 100 us ({r / 100:.2f}x), pull_round <= 300 us ({p / 300:.2f}x)")
    print(f"req_rtt_us_median={r:.1f} pull_round_us_median={p:.1f} msgs_per_s={m:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
