"""MURDOCH auction latency and throughput on loopback UDP multicast.

Starts N bidder processes (`python -m murdoch.sample_bidder`, each bidding a different fixed
score on tasks that finish at once), then runs auctions back to back from this process with a
20 ms bid window: the next announcement goes out as soon as the previous auction has closed.

bids_complete: time from publishing an announcement until the last of the N bids has been
read by the auctioneer's transport (a subscription to each task's negotiation subject notes
every bid's `received_at`, the transport's clock as it read it; late bids, after the window
closed, are included up to `--linger` seconds after the announcement; a bid set still short
then counts as infinite). msgs_per_auction
counts the allocation messages (announce + bids + award); each winner's completion report comes
on top of that.
Last line (on multicast always for the default configuration, one group and port):
bids_complete_ms_p50=<x> bids_complete_ms_p99=<y> auctions_per_s=<z> msgs_per_auction=<m>

With --transport zenoh the same is measured over a Zenoh hub (this process) on
tcp/127.0.0.1 instead of multicast (needs the zenoh extra).

With --reply-lane the same measurement is first made with the reply lane on (replies on a
second group, see `murdoch.multicast`) and printed earlier as its own JSON line and a line
starting with ``reply_lane:``; the default configuration is then measured as usual.

The JSON line before it adds where the time goes, over the measured auctions: the median and
p99 arrival time of the k-th bid, datagrams each process receives per auction, and from
/proc/<pid>/schedstat for the bidders (per process) and the auctioneer: CPU per auction (and
per datagram), wake-ups per auction (time slices run) and the time spent runnable but waiting
for a CPU per wake-up (scheduler latency, which dominates on a busy host).
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import random
import resource
import socket
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable

from murdoch.auction.auctioneer import Phase
from murdoch.auction.messages import Bid, Outcome, TaskSpec, negotiation_subject
from murdoch.multicast import MulticastConfig
from murdoch.node import Node
from murdoch.transport import Subscription
from murdoch.transport_choice import TransportChoice, open_transport
from murdoch.wire import Envelope
from murdoch.zenoh_transport import ZenohConfig


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, math.ceil(q / 100.0 * len(ordered)) - 1))
    return ordered[index]


def proc_stats(pid: int | str) -> tuple[float, float, int]:
    """(CPU seconds, seconds spent runnable but waiting for a CPU, time slices run) of a
    process, from /proc/<pid>/schedstat (zeros where it is not there)."""
    try:
        with open(f"/proc/{pid}/schedstat") as f:
            cpu_ns, run_delay_ns, slices = f.read().split()
    except (OSError, ValueError):
        return 0.0, 0.0, 0
    return int(cpu_ns) / 1e9, int(run_delay_ns) / 1e9, int(slices)


def network_args(choice: TransportChoice) -> list[str]:
    """The sample bidder's options for the bus `choice` describes (bidders are clients)."""
    if choice.kind == "zenoh":
        return ["--transport", "zenoh", "--zenoh-endpoint", choice.zenoh.endpoint]
    config = choice.multicast
    lane = ["--reply-lane"] if config.reply_lane else []
    return ["--group", config.group, "--port", str(config.port), *lane]


def start_bidders(
    count: int, choice: TransportChoice, lifetime_s: float, batch_ms: float
) -> list[subprocess.Popen[str]]:
    procs = []
    for i in range(count):
        cmd = [
            sys.executable, "-m", "murdoch.sample_bidder", "--name", f"bench-b{i}",
            "--score", str(float(i + 1)), *network_args(choice),
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
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--bidders", type=int, default=10)
    parser.add_argument("--auctions", type=int, default=300)
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--bid-window", type=float, default=0.020)
    parser.add_argument("--seed", type=int, default=None, help="picks the groups and ports")
    parser.add_argument("--batch-ms", type=float, default=0.0,
                        help="bidders rest this long after handling traffic while bids are out "
                             "(batches bursts of bids where each bid wakes every bidder)")
    parser.add_argument("--linger", type=float, default=10.0,
                        help="keep counting an auction's bids this long after announcing it "
                             "(a bid set still short then counts as never complete)")
    parser.add_argument("--reply-lane", action="store_true",
                        help="also measure with the reply lane on (printed first)")
    parser.add_argument("--transport", choices=("multicast", "zenoh"), default="multicast",
                        help="zenoh: the same over a Zenoh hub (this process) on "
                             "tcp/127.0.0.1 instead of multicast")
    args = parser.parse_args()
    if args.transport == "zenoh" and args.reply_lane:
        parser.error("--reply-lane is a multicast option")
    rng = random.Random(args.seed)
    if args.transport == "zenoh":
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.bind(("127.0.0.1", 0))
            endpoint = f"tcp/127.0.0.1:{probe.getsockname()[1]}"
        choice = TransportChoice("zenoh", zenoh=ZenohConfig(endpoint=endpoint, hub=True))
        details, summary = measure(args, choice)
        print(json.dumps(details))
        print(summary, flush=True)
        return
    modes = [True, False] if args.reply_lane else [False]
    for reply_lane in modes:
        config = MulticastConfig(group=f"239.255.{rng.randint(1, 254)}.{rng.randint(1, 254)}",
                                 port=rng.randint(20000, 60000), reply_lane=reply_lane)
        details, summary = measure(args, TransportChoice("multicast", multicast=config))
        print(json.dumps(details))
        print(("reply_lane: " if reply_lane else "") + summary, flush=True)


def measure(args: argparse.Namespace, choice: TransportChoice) -> tuple[dict[str, object], str]:
    """Run the auctions on the bus `choice` describes; return the details and the summary
    line."""
    clock = time.perf_counter
    arrivals: dict[str, list[float]] = {}
    announced_at: dict[str, float] = {}
    outcomes: list[Outcome] = []

    def count_bids(times: list[float]) -> Callable[[Envelope], None]:
        def note(envelope: Envelope) -> None:
            if type(envelope.message) is Bid:
                times.append(envelope.received_at)  # the transport's clock as it read it

        return note

    cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    # the auctioneer's transport first: over Zenoh it is the hub the bidders connect to
    transport = open_transport(choice, f"bench-{os.getpid()}", clock)
    try:
        procs = start_bidders(args.bidders, choice, lifetime_s=600.0, batch_ms=args.batch_ms)
    except BaseException:
        transport.close()
        raise
    node = Node(transport, clock, on_outcome=outcomes.append)
    measured: list[str] = []
    spec = TaskSpec("bench", frozenset({"camera"}), bid_window_s=args.bid_window,
                    renew_period_s=1.0, contract_timeout_s=3.0, abandon_after_s=3.0)
    # each task's negotiation subject gets a subscription that notes when every bid on it is
    # read (late ones included); it stays open until all N bids are in or `linger_s` has
    # passed (with a hundred bidders on a busy host the last bids come long after the window
    # closed, and this receiver then holds hundreds of subscriptions at once)
    bid_subs: deque[tuple[float, list[float], Subscription]] = deque()
    linger_s = args.linger

    def retire(now: float) -> None:
        keep: deque[tuple[float, list[float], Subscription]] = deque()
        for opened, times, sub in bid_subs:
            if len(times) >= args.bidders or now - opened > linger_s:
                sub.close()
            else:
                keep.append((opened, times, sub))
        bid_subs.clear()
        bid_subs.extend(keep)
    gc.freeze()  # as the bidders do: no full collection pass over the imported modules
    peak_subs = 0
    try:
        total = args.warmup + args.auctions
        start = 0.0
        base = transport.counters.snapshot()["kinds"]
        for i in range(total):
            if i == args.warmup:
                start = clock()
                base = transport.counters.snapshot()["kinds"]
                stats_before = [proc_stats(p.pid) for p in procs] + [proc_stats("self")]
            sent_at = clock()
            task_id = node.announce(spec)
            announced_at[task_id] = sent_at
            # nothing is read before the next poll, so no bid can be missed
            times = arrivals.setdefault(task_id, [])
            bid_subs.append((sent_at, times, transport.subscribe({negotiation_subject(task_id)},
                                                                 count_bids(times))))
            retire(clock())
            peak_subs = max(peak_subs, len(bid_subs))
            while node.auctioneer.phase_of(task_id) is Phase.BIDDING:
                wake = node.auctioneer.next_wakeup()
                timeout = 0.05 if wake is None else max(0.0, min(0.05, wake - clock()))
                node.step(timeout_s=timeout)
            if i >= args.warmup:
                measured.append(task_id)
        elapsed = clock() - start
        kinds = transport.counters.snapshot()["kinds"]
        stats_after = [proc_stats(p.pid) for p in procs] + [proc_stats("self")]
        limit = clock() + max(5.0, linger_s)
        while (len(outcomes) < total or bid_subs) and clock() < limit:
            node.step(timeout_s=0.01)
            retire(clock())
    finally:
        for _, _, sub in bid_subs:
            sub.close()
        node.close()
        transport.close()
        for proc in procs:
            proc.terminate()
        for proc in procs:
            proc.wait(timeout=10)
    cpu_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    bidder_cpu_s = (cpu_after.ru_utime + cpu_after.ru_stime) - (
        cpu_before.ru_utime + cpu_before.ru_stime)

    latencies_ms = []
    by_rank: list[list[float]] = [[] for _ in range(args.bidders)]
    for task_id in measured:
        for rank, t in enumerate(sorted(arrivals.get(task_id, []))[: args.bidders]):
            by_rank[rank].append((t - announced_at[task_id]) * 1000.0)
    for task_id in measured:
        times = sorted(arrivals.get(task_id, []))
        if len(times) >= args.bidders:
            latencies_ms.append((times[args.bidders - 1] - announced_at[task_id]) * 1000.0)
        else:
            latencies_ms.append(math.inf)
    window_ms = args.bid_window * 1000.0
    finished = {o.task_id for o in outcomes if o.status == "completed"}

    def delta(kind: str, field: str) -> int:
        return int(kinds.get(kind, {}).get(field, 0) - base.get(kind, {}).get(field, 0))

    n = args.auctions
    spent = [tuple(a - b for a, b in zip(after, before, strict=True))
             for after, before in zip(stats_after, stats_before, strict=True)]
    bidders_spent = spent[:-1]
    own_cpu_s, own_wait_s, own_slices = spent[-1]
    bidder_cpu_s_run = sum(s[0] for s in bidders_spent)
    bidder_wait_s = sum(s[1] for s in bidders_spent)
    bidder_slices = sum(s[2] for s in bidders_spent)
    datagrams = sum(int(kinds[k]["recv_msgs"] - base.get(k, {}).get("recv_msgs", 0))
                    for k in kinds)
    allocation_msgs = delta("announce", "sent_msgs") + delta("bid", "recv_msgs") + delta(
        "award", "sent_msgs")
    details: dict[str, object] = {
        "bidders": args.bidders, "auctions": n, "bid_window_s": args.bid_window,
        "batch_ms": args.batch_ms, "transport": choice.kind,
        "reply_lane": choice.kind == "multicast" and choice.multicast.reply_lane,
        "load_avg_1min": os.getloadavg()[0],
        "bid_sets_never_complete": sum(1 for x in latencies_ms if math.isinf(x)),
        "bid_sets_after_close": sum(1 for x in latencies_ms if window_ms < x < math.inf),
        "not_completed": sum(1 for t in measured if t not in finished),
        "reports_per_auction": round(delta("report", "recv_msgs") / n, 3),
        "bidders_cpu_s_total": round(bidder_cpu_s, 2),
        "kth_bid_ms_p50": [round(percentile(r, 50), 2) if r else None for r in by_rank],
        "kth_bid_ms_p99": [round(percentile(r, 99), 2) if r else None for r in by_rank],
        "datagrams_on_group_per_auction": round(datagrams / n, 2),
        "bidder_cpu_ms_per_auction": round(bidder_cpu_s_run / n / args.bidders * 1e3, 3),
        "bidder_cpu_us_per_datagram": round(bidder_cpu_s_run / max(1, datagrams * args.bidders)
                                            * 1e6, 1),
        "bidder_wakeups_per_auction": round(bidder_slices / n / args.bidders, 2),
        "bidder_run_delay_us_per_wakeup": round(bidder_wait_s / max(1, bidder_slices) * 1e6, 1),
        "auctioneer_cpu_ms_per_auction": round(own_cpu_s / n * 1e3, 3),
        "auctioneer_wakeups_per_auction": round(own_slices / n, 2),
        "auctioneer_run_delay_us_per_wakeup": round(own_wait_s / max(1, own_slices) * 1e6, 1),
        "peak_bid_subscriptions": peak_subs,
    }
    p50 = percentile(latencies_ms, 50)
    p99 = percentile(latencies_ms, 99)
    summary = (f"bids_complete_ms_p50={p50:.3f} bids_complete_ms_p99={p99:.3f} "
               f"auctions_per_s={n / elapsed:.1f} msgs_per_auction={allocation_msgs / n:.2f}")
    return details, summary


if __name__ == "__main__":
    main()
