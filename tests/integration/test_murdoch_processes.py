"""Ten bidder processes on real loopback multicast: allocation, a killed winner, a forgery."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from murdoch.auction import AuctionEvent, Bid, Outcome, TaskSpec
from murdoch.auth import TeamKey
from murdoch.endpoint import EndpointOptions
from murdoch.multicast import MulticastConfig, MulticastTransport, open_multicast_socket
from murdoch.node import Node


def free_config() -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port)


def loopback_multicast_available(config: MulticastConfig) -> bool:
    try:
        with MulticastTransport("probe", time.monotonic, config) as probe:
            sub = probe.subscribe({"probe"})
            probe.publish({"probe"}, Bid("p", 1, "probe", 0.0))
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline:
                probe.poll(0.05)
                if sub.drain():
                    return True
    except OSError:
        return False
    return False


class Bidders:
    """Owns the bidder processes; stops them all at the end."""

    def __init__(self, config: MulticastConfig) -> None:
        self.config = config
        self.procs: dict[str, subprocess.Popen[str]] = {}

    def start(self, name: str, score: float, subjects: str = "camera,mobile",
              key: str | None = None, lifetime_s: float = 40.0) -> None:
        cmd = [sys.executable, "-m", "murdoch.sample_bidder", "--name", name,
               "--score", str(score), "--subjects", subjects, "--group", self.config.group,
               "--port", str(self.config.port), "--lifetime", str(lifetime_s), "--quiet"]
        if key:
            cmd += ["--key", key]
        if self.config.reply_lane:
            cmd.append("--reply-lane")
        self.procs[name] = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)

    def wait_ready(self) -> None:
        for name, proc in self.procs.items():
            assert proc.stdout is not None
            line = proc.stdout.readline()
            assert json.loads(line) == {"ready": name}

    def kill(self, name: str) -> None:
        proc = self.procs[name]
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)

    def stop_all(self) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.terminate()
        for proc in self.procs.values():
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=10)


def _owned_bidders(config: MulticastConfig) -> Iterator[Bidders]:
    if not loopback_multicast_available(config):
        pytest.skip("UDP multicast on the loopback interface is not available on this machine")
    owner = Bidders(config)
    try:
        yield owner
    finally:
        owner.stop_all()


@pytest.fixture
def bidders() -> Iterator[Bidders]:
    yield from _owned_bidders(free_config())


@pytest.fixture
def lane_bidders() -> Iterator[Bidders]:
    yield from _owned_bidders(dataclasses.replace(free_config(), reply_lane=True))


def run_until(node: Node, done, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        node.step(timeout_s=0.01)


@pytest.mark.timeout(90)
def test_ten_processes_best_metric_wins_and_a_killed_winner_is_replaced(
    bidders: Bidders,
) -> None:
    for k in range(10):
        bidders.start(f"proc-b{k}", score=float(k))
    bidders.start("no-camera", score=100.0, subjects="laser,mobile")
    bidders.wait_ready()
    clock = time.monotonic
    events: list[AuctionEvent] = []
    outcomes: list[Outcome] = []
    with MulticastTransport(f"tester-{os.getpid()}", clock, bidders.config) as transport:
        node = Node(transport, clock, observer=events.append, on_outcome=outcomes.append)
        # generous timings: this machine may be busy, and a late bid must not change the result
        spec = TaskSpec("track", frozenset({"camera"}), duration_s=2.5, bid_window_s=1.0,
                        renew_period_s=0.3, contract_timeout_s=1.5, abandon_after_s=1.5)
        task_id = node.announce(spec)
        run_until(node, lambda: any(e.kind == "award" for e in events), 10.0)
        (award,) = [e for e in events if e.kind == "award"]
        assert award.detail["winner"] == "proc-b9"
        assert award.detail["bids"] == 10  # the laser-only robot never heard the task
        run_until(node, lambda: any(e.kind == "progress" for e in events), 5.0)
        bidders.kill("proc-b9")
        run_until(node, lambda: bool(outcomes), 30.0)
        node.close()
    (outcome,) = outcomes
    assert (outcome.task_id, outcome.status, outcome.winner) == (task_id, "completed", "proc-b8")
    kinds = [e.kind for e in events]
    assert "reallocation" in kinds and outcome.attempts == 2
    awards = [e.detail["winner"] for e in events if e.kind == "award"]
    assert awards == ["proc-b9", "proc-b8"]
    # messages per round: 1 announcement + bids + 1 award, the rest are renewals and progress
    sent, received = transport.counters.sent, transport.counters.received
    assert sent("announce") == 2 and sent("award") == 2
    assert received("bid") == 10 + 9


@pytest.mark.timeout(60)
def test_forged_and_replayed_bids_are_rejected_on_a_keyed_team(bidders: Bidders) -> None:
    key = "team-key-for-tests"
    bidders.start("honest-1", score=1.0, key=key)
    bidders.start("honest-2", score=2.0, key=key)
    bidders.wait_ready()
    clock = time.monotonic
    events: list[AuctionEvent] = []
    outcomes: list[Outcome] = []
    config = bidders.config
    keyed = EndpointOptions(key=TeamKey(key))
    forged = EndpointOptions(key=TeamKey("not-the-key"))
    with MulticastTransport("keyed-user", clock, config, keyed) as transport, \
            MulticastTransport("forger", clock, config, forged) as forger, \
            MulticastTransport("replayer", clock, config) as replayer:
        captured: list[bytes] = []
        wire_tap = open_multicast_socket(config)  # one group carries everything
        node = Node(transport, clock, observer=events.append, on_outcome=outcomes.append)
        spec = TaskSpec("track", frozenset({"camera"}), duration_s=0.5, bid_window_s=1.0,
                        renew_period_s=0.3, contract_timeout_s=1.5, abandon_after_s=1.5)
        task_id = node.announce(spec)
        negotiation = {f"task.{task_id}"}
        forger.publish(negotiation, Bid(task_id, 1, "forger", 1000.0))
        unsigned = replayer.codec.encode_frame("replayer", 0, frozenset(negotiation),
                                               Bid(task_id, 1, "replayer", 500.0))
        replayer.send_raw(unsigned, reply=True)
        # capture an honest signed bid off the wire and send it again
        deadline = clock() + 3.0
        while not captured and clock() < deadline:
            node.step(timeout_s=0.005)
            try:
                data = wire_tap.recv(65536)
            except BlockingIOError:
                continue
            if json.loads(data)["h"][1:3] in (["bid", "honest-1"], ["bid", "honest-2"]):
                captured.append(data)
        wire_tap.close()
        assert captured
        replayer.send_raw(captured[0], reply=True)
        run_until(node, lambda: bool(outcomes), 10.0)
        node.close()
    (outcome,) = outcomes
    assert outcome.status == "completed" and outcome.winner == "honest-2"
    bids = [e.detail["bidder"] for e in events if e.kind == "bid"]
    assert sorted(bids) == ["honest-1", "honest-2"]
    dropped = transport.counters.dropped
    assert dropped.get("auth_failed", 0) >= 2  # the forged and the unsigned bid
    assert dropped.get("replayed", 0) >= 1


@pytest.mark.timeout(60)
def test_processes_on_the_reply_lane_run_auctions_to_completion(lane_bidders: Bidders) -> None:
    for k in range(4):
        lane_bidders.start(f"lane-b{k}", score=float(k))
    lane_bidders.wait_ready()
    clock = time.monotonic
    events: list[AuctionEvent] = []
    outcomes: list[Outcome] = []
    with MulticastTransport(f"lane-user-{os.getpid()}", clock, lane_bidders.config) as transport:
        node = Node(transport, clock, observer=events.append, on_outcome=outcomes.append)
        for _ in range(3):
            spec = TaskSpec("track", frozenset({"camera"}), duration_s=0.0, bid_window_s=0.5,
                            renew_period_s=0.3, contract_timeout_s=1.5, abandon_after_s=1.5)
            node.announce(spec)
            count = len(outcomes) + 1
            run_until(node, lambda n=count: len(outcomes) >= n, 10.0)
        node.close()
    assert [(o.status, o.winner) for o in outcomes] == [("completed", "lane-b3")] * 3
    assert [e.detail["bids"] for e in events if e.kind == "award"] == [4, 4, 4]
    assert transport.counters.received("bid") == 12
