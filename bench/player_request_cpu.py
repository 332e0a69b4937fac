"""CPU time and system calls per Player request, on each side of the connection.

Wall-clock round trips (``bench/player_latency.py``) need an idle machine; the CPU each
side spends per request is disturbed far less by other load. Starts ``player-server``
(paused) on the ``simple`` world like ``player_latency.py``, subscribes the same six
devices, then times ``runs`` batches of ``n`` position2d GET_GEOM requests:

* server_cpu_us: CPU time of every thread of the server process per request (from
  ``/proc/<pid>/task/*/schedstat``, in ns), less the same process's CPU over as long
  a time idle;
* client_cpu_us: ``time.thread_time()`` of the requesting thread per request;
* echo_server_cpu_us, echo_client_cpu_us: the same for a bare TCP echo round trip of a
  request-sized message (``player_latency.RawEcho``), the floor either side could reach.

``--strace`` also counts the system calls of one batch on both sides (``strace -c``
attached to the server and to this process; needs strace and the right to trace).
The last line reads ``server_cpu_us=<s> client_cpu_us=<c> [server_syscalls=<x>
client_syscalls=<y>]`` (medians over the runs; syscalls per request).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from player_latency import start_server, warmed_up

from player_server.client import (
    Position2dProxy,
)


def process_cpu_ns(pid: int) -> int:
    """CPU time of every thread of ``pid`` so far, in ns."""
    total = 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            total += int((task / "schedstat").read_text().split()[0])
        except (OSError, ValueError, IndexError):
            continue  # a thread that ended meanwhile
    return total


def strace_summary(path: Path) -> dict[str, int]:
    """System call counts from ``strace -c`` output."""
    counts: dict[str, int] = {}
    for line in path.read_text().splitlines():
        m = re.match(r"\s*[\d.]+\s+[\d.]+\s+\d+\s+(\d+)\s+(?:\d+\s+)?(\w+)\s*$", line)
        if m and m.group(2) != "total":
            counts[m.group(2)] = int(m.group(1))
    return counts


class Tracer:
    """``strace -c -f`` attached to a process until ``stop``."""

    def __init__(self, pid: int, out: Path) -> None:
        self.out = out
        self.proc = subprocess.Popen(["strace", "-c", "-f", "-o", str(out), "-p", str(pid)],
                                     stderr=subprocess.DEVNULL)
        time.sleep(0.5)  # attached

    def stop(self) -> dict[str, int]:
        self.proc.send_signal(signal.SIGINT)
        self.proc.wait(10)
        return strace_summary(self.out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("-n", type=int, default=5000, help="requests per run")
    ap.add_argument("--world", default="simple")
    ap.add_argument("--strace", action="store_true", help="also count system calls")
    args = ap.parse_args()
    proc, port = start_server(args.world)
    try:
        cl, proxies, echo = warmed_up(port, 500)
        pos = proxies[0]
        assert isinstance(pos, Position2dProxy)
        server, client, echo_srv, echo_cli = [], [], [], []
        for run in range(args.runs):
            t0, s0 = time.perf_counter(), process_cpu_ns(proc.pid)
            time.sleep(0.5)
            idle_per_s = (process_cpu_ns(proc.pid) - s0) / (time.perf_counter() - t0)
            t0, s0, c0 = time.perf_counter(), process_cpu_ns(proc.pid), time.thread_time_ns()
            for _ in range(args.n):
                pos.get_geometry()
            c1, s1, t1 = time.thread_time_ns(), process_cpu_ns(proc.pid), time.perf_counter()
            srv = (s1 - s0 - idle_per_s * (t1 - t0)) / args.n / 1e3
            cli = (c1 - c0) / args.n / 1e3
            server.append(srv)
            client.append(cli)
            s0, c0 = process_cpu_ns(echo.proc.pid), time.thread_time_ns()
            for _ in range(args.n):
                echo.round_trip()
            c1, s1 = time.thread_time_ns(), process_cpu_ns(echo.proc.pid)
            echo_srv.append((s1 - s0) / args.n / 1e3)
            echo_cli.append((c1 - c0) / args.n / 1e3)
            print(f"run {run + 1}: server {srv:.1f} us, client {cli:.1f} us CPU per request "
                  f"(wall {(t1 - t0) / args.n * 1e6:.1f} us; server idle "
                  f"{idle_per_s / 1e6:.2f} ms/s); raw TCP echo: echo process "
                  f"{echo_srv[-1]:.1f} us, client {echo_cli[-1]:.1f} us", flush=True)
        line = (f"server_cpu_us={statistics.median(server):.1f} "
                f"client_cpu_us={statistics.median(client):.1f} "
                f"echo_server_cpu_us={statistics.median(echo_srv):.1f} "
                f"echo_client_cpu_us={statistics.median(echo_cli):.1f}")
        if args.strace:
            if shutil.which("strace") is None:
                raise SystemExit("strace is not installed")
            with tempfile.TemporaryDirectory() as tmp:
                srv_t = Tracer(proc.pid, Path(tmp) / "server")
                cli_t = Tracer(os.getpid(), Path(tmp) / "client")
                for _ in range(args.n):
                    pos.get_geometry()
                cli_calls = cli_t.stop()
                srv_calls = srv_t.stop()
            for side, calls in (("server", srv_calls), ("client", cli_calls)):
                per = {k: v / args.n for k, v in sorted(calls.items(), key=lambda kv: -kv[1])}
                print(f"{side} system calls per request: "
                      + ", ".join(f"{k} {v:.2f}" for k, v in per.items() if v >= 0.01))
            line += (f" server_syscalls={sum(srv_calls.values()) / args.n:.2f}"
                     f" client_syscalls={sum(cli_calls.values()) / args.n:.2f}")
        cl.close()
        echo.close()
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
