"""MURDOCH auction latency and throughput on loopback UDP multicast.

Starts N bidder processes (`python -m murdoch.sample_bidder`, each bidding a different fixed
score on tasks that finish at once), then runs auctions back to back from this process with a
20 ms bid window. For each auction it records the time from publishing the announcement until
the last of the N bids has been handled here (bids_complete), and counts the allocation
messages (announce + bids + award; the winner's completion report is counted separately).
Last line: bids_complete_ms_p50=<x> bids_complete_ms_p99=<y> auctions_per_s=<z> msgs_per_auction=<m>
"""

from __future__ import annotations

import argparse
import json
import random
import resource
import statistics
import subprocess
import sys
import time

from murdoch.auction.messages import AuctionEvent, Outcome, TaskSpec
from murdoch.multicast import MulticastConfig, MulticastTransport
from murdoch.node import Node


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, round(q / 100.0 * (len(ordered) - 1))))
    return ordered[index]


def start_bidders(
    count: int, config: MulticastConfig, lifetime_s: float, batch_ms: float
) -> list[subprocess.Popen[str]]:
    procs = []
    for i in range(count):
        cmd = [
            sys.executable, "-m", "murdoch.sample_bidder", "--name", f"bench-b{i}",
            "--score", str(float(i + 1)), "--group", config.group, "--port", str(config.port),
            "--lifetime", str(lifetime_s), "--quiet", "--batch-ms", str(batch_ms),
        ]
        procs.append(subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True))
    for proc in procs:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        if "ready" not in line:
            raise RuntimeError(f"bidder did not start: {line!r}")
    return procs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bidders", type=int, default=10)
    parser.add_argument("--auctions", type=int, default=300)
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--bid-window", type=float, default=0.020)
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--batch-ms", type=float, default=2.0,
                        help="bidders rest this long after handling traffic (robot loop period)")
    args = parser.parse_args()

    rng = random.Random(args.seed)
    config = MulticastConfig(group=f"239.255.{rng.randint(1, 254)}.{rng.randint(1, 254)}",
                             port=rng.randint(20000, 60000))
    clock = time.perf_counter
    bid_times: dict[str, list[float]] = {}
    outcomes: list[Outcome] = []

    def observe(event: AuctionEvent) -> None:
        if event.kind == "bid":
            bid_times.setdefault(event.task_id, []).append(event.time_s)

    cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    procs = start_bidders(args.bidders, config, lifetime_s=120.0, batch_ms=args.batch_ms)
    transport = MulticastTransport("bench-auctioneer", clock, config)
    latencies_ms: list[float] = []
    incomplete = 0
    closed: set[str] = set()

    def watch(event: AuctionEvent) -> None:
        observe(event)
        if event.kind == "close":
            closed.add(event.task_id)

    node = Node(transport, clock, on_outcome=outcomes.append, observer=watch)
    task_ids: list[str] = []
    try:
        total = args.warmup + args.auctions
        start = 0.0
        base = dict(transport.counters.snapshot()["kinds"])
        for i in range(total):
            if i == args.warmup:
                start = clock()
                base = dict(transport.counters.snapshot()["kinds"])
            spec = TaskSpec("bench", frozenset({"camera"}), bid_window_s=args.bid_window,
                            renew_period_s=1.0, contract_timeout_s=3.0, abandon_after_s=3.0)
            announced_at = clock()
            task_id = node.announce(spec)
            # the next auction starts as soon as this one has closed and awarded
            while task_id not in closed:
                wake = node.auctioneer.next_wakeup()
                timeout = 0.001 if wake is None else max(0.0, min(0.002, wake - clock()))
                node.step(timeout_s=timeout)
            if i < args.warmup:
                continue
            task_ids.append(task_id)
            times = bid_times.pop(task_id, [])
            if len(times) < args.bidders:
                incomplete += 1
            elif times:
                latencies_ms.append((max(times) - announced_at) * 1000.0)
        elapsed = clock() - start
        kinds = transport.counters.snapshot()["kinds"]
        limit = clock() + 5.0
        while len(outcomes) < total and clock() < limit:
            node.step(timeout_s=0.01)
        finished = {o.task_id for o in outcomes if o.status == "completed"}
        failures = sum(1 for t in task_ids if t not in finished)
    finally:
        node.close()
        transport.close()
        for proc in procs:
            proc.terminate()
        for proc in procs:
            proc.wait(timeout=10)
    cpu_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    bidder_cpu_s = (cpu_after.ru_utime + cpu_after.ru_stime) - (
        cpu_before.ru_utime + cpu_before.ru_stime)

    def delta(kind: str, field: str) -> int:
        return kinds.get(kind, {}).get(field, 0) - base.get(kind, {}).get(field, 0)

    allocation_msgs = delta("announce", "sent_msgs") + delta("bid", "recv_msgs") + delta(
        "award", "sent_msgs")
    reports = delta("report", "recv_msgs")  # counted until the last close
    n = args.auctions
    print(json.dumps({
        "bidders": args.bidders, "auctions": n, "bid_window_s": args.bid_window,
        "incomplete_bid_sets": incomplete, "not_completed": failures,
        "batch_ms": args.batch_ms,
        "reports_per_auction": round(reports / n, 3),
        "bidders_cpu_s_total": round(bidder_cpu_s, 2),
        "bids_complete_ms_mean": round(statistics.fmean(latencies_ms), 3) if latencies_ms else None,
        "bids_complete_ms_max": round(max(latencies_ms), 3) if latencies_ms else None,
    }))
    p50 = percentile(latencies_ms, 50) if latencies_ms else float("nan")
    p99 = percentile(latencies_ms, 99) if latencies_ms else float("nan")
    print(f"bids_complete_ms_p50={p50:.3f} bids_complete_ms_p99={p99:.3f} "
          f"auctions_per_s={n / elapsed:.1f} msgs_per_auction={allocation_msgs / n:.2f}")


if __name__ == "__main__":
    main()
