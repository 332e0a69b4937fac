"""A stand-alone bidder process for demonstrations, tests and benchmarks.

It joins the team's bus (multicast, or Zenoh with `--transport zenoh`) with some resource
subjects, bids a fixed score on every task it hears, "executes" an awarded task by waiting
the task's `duration_s` on its clock while reporting progress, then reports completion. It
prints one line per event on stdout (JSON) and exits after `--lifetime` seconds (or at
SIGTERM / Ctrl-C). With the environment variable ``MURDOCH_BIDDER_PROFILE_DIR`` set it
writes a cProfile of its loop, in CPU time, to ``<dir>/<name>.prof`` on exit. Run it as
``python -m murdoch.sample_bidder``.
"""

from __future__ import annotations

import cProfile
import gc
import json
import os
import signal
import sys
import time
from collections.abc import Callable
from typing import Any

import click

from murdoch.auction.bidder import Contract
from murdoch.auction.messages import Announce, AuctionEvent
from murdoch.node import Node
from murdoch.pubsub_cli import _network_options, _open

PROFILE_ENV = "MURDOCH_BIDDER_PROFILE_DIR"
"""When set, each bidder writes a CPU-time profile of its loop there (<name>.prof) on exit."""


class TimedExecutor:
    """Completes each contract once its announced duration has passed on the clock."""

    def __init__(self, node_ref: list[Node]) -> None:
        self._node_ref = node_ref
        self.current: Contract | None = None

    def start(self, contract: Contract) -> None:
        self.current = contract
        if contract.announce.duration_s <= 0.0:
            self.current = None
            self._node_ref[0].complete(contract.task_id, "done")

    def stop(self, contract: Contract, reason: str) -> None:
        del contract, reason
        self.current = None

    def step(self, now: float) -> None:
        contract = self.current
        if contract is None:
            return
        node = self._node_ref[0]
        elapsed = now - contract.awarded_at
        duration = contract.announce.duration_s
        if elapsed >= duration:
            self.current = None
            node.complete(contract.task_id, "done")
        else:
            node.progress(contract.task_id, elapsed / duration)


@click.command()
@click.option("--name", required=True, help="Agent id (a subject-safe name).")
@click.option("--score", type=float, required=True, help="The score bid on every task.")
@click.option("--subjects", default="camera,mobile", show_default=True)
@click.option("--lifetime", type=float, default=30.0, show_default=True, help="Seconds to run.")
@click.option("--quiet", is_flag=True, help="Print only the ready line.")
@click.option(
    "--batch-ms", type=float, default=0.0, show_default=True,
    help="Rest this long after handling traffic while bids are out (read bursts at once).",
)
@_network_options
def main(
    name: str,
    score: float,
    subjects: str,
    lifetime: float,
    quiet: bool,
    batch_ms: float,
    **net: Any,
) -> None:
    clock = time.monotonic

    def show(event: AuctionEvent) -> None:
        if not quiet:
            print(json.dumps(event.to_dict()), flush=True)

    def metric(announce: Announce) -> float:
        del announce
        return score

    node_ref: list[Node] = []
    executor = TimedExecutor(node_ref)
    transport = _open(name, clock, net)
    node = Node(
        transport,
        clock,
        subjects=subjects,
        metric=metric,
        on_start=executor.start,
        on_stop=executor.stop,
        observer=None if quiet else show,
    )
    node_ref.append(node)
    # SIGTERM ends the loop like Ctrl-C: the transport is closed and a profile is written
    signal.signal(signal.SIGTERM, _interrupt)
    # what exists now lives as long as the process: keep it out of the cyclic collector's
    # full passes (a few ms each, a stall in the middle of some auction)
    gc.freeze()
    profile_dir = os.environ.get(PROFILE_ENV)
    profiler = cProfile.Profile(time.process_time) if profile_dir else None
    print(json.dumps({"ready": name}), flush=True)
    try:
        if profiler is not None:
            profiler.enable()
        run(node, executor, clock, time.sleep, lifetime, batch_ms / 1000.0)
    except KeyboardInterrupt:
        pass
    finally:
        if profiler is not None and profile_dir:
            profiler.disable()
            profiler.dump_stats(os.path.join(profile_dir, f"{name}.prof"))
        node.close()
        transport.close()
    sys.exit(0)


def _interrupt(signum: int, frame: object) -> None:
    del signum, frame
    raise KeyboardInterrupt


def run(
    node: Node,
    executor: TimedExecutor,
    clock: Callable[[], float],
    sleep: Callable[[float], None],
    lifetime_s: float,
    batch_s: float,
) -> None:
    """The bidder's loop: wait for traffic, handle it, advance the task, for `lifetime_s`.

    With `batch_s`, after handling traffic while bids are out (the other bids of the round are
    arriving) the loop rests, so that they are read in one go instead of one wake-up each.
    """
    end = clock() + lifetime_s
    while clock() < end:
        handled = node.step(timeout_s=0.05)
        executor.step(clock())
        if handled and batch_s > 0 and node.bidder is not None and node.bidder.pending_bids:
            sleep(batch_s)


if __name__ == "__main__":
    main()
