"""Player client/server latency and throughput over loopback TCP.

Starts ``player-server`` (paused, so rounds measure the protocol path and not physics) on
the ``simple`` world in its own process, then measures with our client:

* req_rtt_us_median: position2d GET_GEOM request -> ACK round trip;
* pull_round_us_median: one PULL round (REQ DATA, ACK, 6 DATA, SYNCH) with position2d,
  sonar, laser, ranger, bumper and power subscribed;
* msgs_per_s: DATA messages received per second by back-to-back PULL rounds;
* raw_tcp_rtt_us_median: the floor, a plain loopback TCP round trip of a request-sized
  message to an echo process (no Player), measured in the same runs, alternating with the
  Player request; ``rtt_ratio`` = req_rtt / raw_tcp_rtt;
* nagle_tick_ms_median: a lockstep tick of a client that, like stock libplayerc, leaves
  Nagle's algorithm on and writes a velocity command (no reply) and then REQ DATA as two
  separate sends (the server's prompt ACK keeps the second from waiting ~40 ms).

Where the processes run matters on an idle virtual machine: a process woken on another,
idle core waits for that core to come out of its idle state (about 65 us per round trip on
the 2-core test machine, for the bare echo as for the server), while one woken on the
waker's core does not. The kernel often places the echo beside the client and the server
(several threads) elsewhere, which compares unlike with unlike. ``--cpus same`` runs the
client, the server and the echo on one CPU; ``--cpus split`` the client on one and the
server and the echo on another; ``--cpus free`` (the default) leaves placement to the kernel.

Each figure is the median over several runs (each run's own median for latencies).
The last line reads ``req_rtt_us_median=<x> pull_round_us_median=<y> msgs_per_s=<z>
raw_tcp_rtt_us_median=<r> rtt_ratio=<q> nagle_tick_ms_median=<t>``.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import struct
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
from player_server.client.proxy import Proxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import encode_message
from player_server.protocol import player_msgs as pm
from player_server.protocol.common import DevAddr, Pose2d

#: the CPUs --cpus chose for the server and the echo (None: not pinned)
_peer_cpus: set[int] | None = None


def _pin_peer() -> None:
    """In a child before it runs: the placement --cpus chose for the server and the echo."""
    if _peer_cpus is not None:
        os.sched_setaffinity(0, _peer_cpus)


def place(mode: str) -> None:
    """Pin this client (and choose the server's and echo's CPUs) as --cpus says."""
    global _peer_cpus
    cpus = sorted(os.sched_getaffinity(0))
    if mode == "free":
        return
    if mode == "split" and len(cpus) < 2:
        raise SystemExit("--cpus split needs two CPUs")
    _peer_cpus = {cpus[0]} if mode == "same" else {cpus[1]}
    os.sched_setaffinity(0, {cpus[0]})


def start_server(world: str, *mode: str) -> tuple[subprocess.Popen[str], int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "player_server.server", world, "-p", "0", "--speedup", "0",
         "-q", *(mode or ("--paused",))],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, preexec_fn=_pin_peer)
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


_ECHO = """
import socket, sys
ls = socket.socket()
ls.bind(("127.0.0.1", 0))
ls.listen(1)
print(ls.getsockname()[1], flush=True)
c, _ = ls.accept()
c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
while True:
    b = c.recv(65536)
    if not b:
        break
    c.sendall(b)
"""
#: a Player request with a header and no body, as GET_GEOM is
_REQUEST_SIZE = 40


class RawEcho:
    """Another process echoing what it receives: the loopback TCP round trip floor."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen([sys.executable, "-c", _ECHO], stdout=subprocess.PIPE,
                                     text=True, preexec_fn=_pin_peer)
        assert self.proc.stdout is not None
        port = int(self.proc.stdout.readline())
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.msg = b"q" * _REQUEST_SIZE

    def round_trip(self) -> None:
        self.sock.sendall(self.msg)
        got = 0
        while got < _REQUEST_SIZE:
            got += len(self.sock.recv(65536))

    def close(self) -> None:
        self.sock.close()
        self.proc.wait(10)


#: the devices both benches subscribe
DEVICES = (Position2dProxy, SonarProxy, LaserProxy, RangerProxy, BumperProxy, PowerProxy)


def warmed_up(port: int, rounds: int) -> tuple[PlayerClient, list[Proxy], RawEcho]:
    """An observer client of the server on `port` subscribed to DEVICES, and a bare echo,
    both through `rounds` round trips first (the position2d proxy is the list's first)."""
    cl = PlayerClient("127.0.0.1", port, lockstep=False).connect()
    proxies = [cl.subscribe(p) for p in DEVICES]
    pos = proxies[0]
    assert isinstance(pos, Position2dProxy)
    for _ in range(rounds):
        cl.read()
        pos.get_geometry()
    echo = RawEcho()
    for _ in range(rounds):
        echo.round_trip()
    return cl, proxies, echo


def nagle_ticks(world: str, runs: int, n: int) -> float:
    """Median lockstep tick (ms) of a client with Nagle on sending command and REQ DATA as
    two writes, reading its round to the SYNCH."""
    proc, port = start_server(world, "--lockstep")
    try:
        sock = socket.create_connection(("127.0.0.1", port))
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) == 0  # Nagle on
        buf = bytearray()

        def read_until(mtype: int) -> None:
            nonlocal buf
            while True:
                while len(buf) >= 40:
                    size = struct.unpack_from(">I", buf, 36)[0]
                    if len(buf) < 40 + size:
                        break
                    t = struct.unpack_from(">I", buf, 16)[0]
                    del buf[:40 + size]
                    if t == mtype:
                        return
                chunk = sock.recv(1 << 16)
                if not chunk:
                    raise ConnectionError("server closed")
                buf += chunk

        def exactly(n_bytes: int) -> None:
            nonlocal buf
            while len(buf) < n_bytes:
                buf += sock.recv(1 << 16)
            del buf[:n_bytes]

        sock.settimeout(30.0)
        exactly(32)  # banner
        sock.sendall(encode_message(1, 0, 3, c.PLAYER_REQ_DATAMODE,
                                    pm.DeviceDatamodeReq(c.PLAYER_DATAMODE_PULL)))
        read_until(4)
        sock.sendall(encode_message(1, 0, 3, c.PLAYER_REQ_DEV, pm.DeviceReq(
            DevAddr(0, 0, 4, 0), c.PLAYER_OPEN_MODE, "")))
        read_until(4)
        cmd = encode_message(4, 0, 2, c.PLAYER_POSITION2D_CMD_VEL,
                             am.Position2dCmdVel(Pose2d(0.0, 0.0, 0.0), 1))
        req = encode_message(1, 0, 3, c.PLAYER_REQ_DATA)

        def tick() -> None:
            sock.send(cmd)  # a command: no reply
            sock.send(req)  # the next write: Nagle holds it until the command is ACKed
            read_until(5)  # ... the round's SYNCH

        for _ in range(20):
            tick()
        result = statistics.median(statistics.median(timed(tick, n)) for _ in range(runs))
        sock.close()
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    return result * 1e3


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
        for p in DEVICES:
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
    ap.add_argument("--cpus", choices=("free", "same", "split"), default="free",
                    help="where the client, the server and the echo run (see above)")
    args = ap.parse_args()
    place(args.cpus)
    proc, port = start_server(args.world)
    try:
        cl, proxies, echo = warmed_up(port, 200)
        pos = proxies[0]
        assert isinstance(pos, Position2dProxy)
        req, pull, rate, raw = [], [], [], []
        for run in range(args.runs):
            w = statistics.median(timed(echo.round_trip, args.n)) * 1e6
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
            raw.append(w)
            print(f"run {run + 1}: req_rtt {r:.1f} us (raw tcp {w:.1f} us), pull_round "
                  f"{p:.1f} us, {msgs:.0f} DATA msgs/s", flush=True)
        cl.close()
        echo.close()
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    lockstep = lockstep_rounds(args.world, args.runs, max(args.n // 4, 50))
    print(f"for information: a lockstep tick (physics step + round, one robot process) "
          f"takes {lockstep:.1f} us median")
    nagle = nagle_ticks(args.world, args.runs, max(args.n // 4, 50))
    r, p, m = statistics.median(req), statistics.median(pull), statistics.median(rate)
    w = statistics.median(raw)
    print(f"targets: req_rtt <= 100 us ({r / 100:.2f}x), pull_round <= 300 us ({p / 300:.2f}x),"
          f" Nagle client lockstep tick <= 2 ms ({nagle / 2:.2f}x)")
    print(f"req_rtt_us_median={r:.1f} pull_round_us_median={p:.1f} msgs_per_s={m:.0f} "
          f"raw_tcp_rtt_us_median={w:.1f} rtt_ratio={r / w:.2f} nagle_tick_ms_median={nagle:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
