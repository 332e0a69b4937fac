"""Signed datagrams whose fields fail their type checks (an attempt "one", a score of
infinity or NaN), over real multicast on loopback: every receiver rejects and counts them,
and `murdoch listen` shows them flagged and counts them."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest

from murdoch.auction import AUCTION_CODEC, Announce, Bid, Contract, Outcome, TaskSpec
from murdoch.auth import TeamKey
from murdoch.endpoint import EndpointOptions
from murdoch.multicast import MulticastConfig, MulticastTransport
from murdoch.node import Node

SECRET = "team-key-for-invalid-frames"
KEY = TeamKey(SECRET)


def free_config() -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port)


def multicast_works(config: MulticastConfig) -> bool:
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


@pytest.fixture
def config() -> MulticastConfig:
    cfg = free_config()
    if not multicast_works(cfg):
        pytest.skip("UDP multicast on the loopback interface is not available on this machine")
    return cfg


def tampered(message: Any, subjects: Iterable[str], seq: int, edit: tuple[bytes, bytes],
             key: TeamKey | None = KEY, sender: str = "ghost") -> bytes:
    """A datagram of `message` as a sender writes it, its body edited, then signed."""
    data = AUCTION_CODEC.encode_frame(sender, seq, frozenset(subjects), message, "g1")
    old, new = edit
    assert data.count(old) == 1, data
    data = data.replace(old, new)
    return key.sign(data) if key is not None else data


def run_until(nodes: list[Node], done: Callable[[], bool], timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        for node in nodes:
            node.step(timeout_s=0.01)


@pytest.mark.timeout(60)
def test_signed_frames_with_ill_typed_fields_are_rejected_and_counted_by_nodes(
    config: MulticastConfig,
) -> None:
    key = KEY
    clock = time.monotonic
    started: list[Contract] = []
    outcomes: list[Outcome] = []
    spec = TaskSpec("track", frozenset({"camera"}), bid_window_s=1.0, renew_period_s=0.5,
                    contract_timeout_s=5.0, abandon_after_s=5.0)
    with MulticastTransport("user", clock, config, EndpointOptions(key=key)) as user_tx, \
            MulticastTransport("r1", clock, config, EndpointOptions(key=key)) as robot_tx, \
            MulticastTransport("ghost", clock, config, EndpointOptions(key=key)) as ghost:
        user = Node(user_tx, clock, on_outcome=outcomes.append)
        robot = Node(robot_tx, clock, subjects={"camera"}, metric=lambda ann: 1.0,
                     on_start=started.append)
        # an announcement whose attempt is "one": the robot must not bid on it
        fake = Announce("fake.1", 1, "fake", ("camera",), {}, 0.0, (), "task.fake.1", 0.5, 1.0,
                        3.0, None)
        ghost.send_raw(tampered(fake, {"camera", "idle"}, 0, (b'"attempt":1', b'"attempt":"one"')))
        run_until([robot], lambda: robot_tx.counters.dropped.get("bad_fields", 0) >= 1)
        assert robot_tx.counters.dropped.get("bad_fields") == 1
        assert robot.bidder is not None and robot.bidder.pending_bids == 0

        task_id = user.announce(spec)
        negotiation = {f"task.{task_id}"}
        # bids that would win the round if they were accepted
        for seq, edit in enumerate([(b'"score":9.0', b'"score":1e999'),
                                    (b'"score":9.0', b'"score":-1e999'),
                                    (b'"attempt":1', b'"attempt":"one"'),
                                    (b'"score":9.0', b'"score":NaN'),
                                    (b'"score":9.0', b'"score":Infinity')], start=1):
            ghost.send_raw(tampered(Bid(task_id, 1, "ghost", 9.0), negotiation, seq, edit),
                           reply=True)
        run_until([user, robot], lambda: bool(started))
        assert [c.task_id for c in started] == [task_id]
        robot.complete(task_id, "done")
        run_until([user, robot], lambda: bool(outcomes))
        (outcome,) = outcomes
        assert (outcome.status, outcome.winner, outcome.attempts) == ("completed", "r1", 1)
        dropped = user_tx.counters.dropped
        assert dropped.get("bad_fields") == 3 and dropped.get("malformed") == 2
        user.close()
        robot.close()


def murdoch_command() -> list[str]:
    script = Path(sys.executable).with_name("murdoch")
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from experiments.cli import main; main()"]


def strict_json(line: str) -> Any:
    def refuse(name: str) -> Any:
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(line, parse_constant=refuse)


@pytest.mark.timeout(60)
def test_listen_flags_and_counts_signed_frames_with_ill_typed_fields(
    config: MulticastConfig,
) -> None:
    network = ["--group", config.group, "--port", str(config.port), "--key", SECRET]
    listeners = [
        subprocess.Popen([*murdoch_command(), "listen", *mode, "--duration", "30", "--count",
                          "4", *network],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for mode in (["--json"], [])
    ]
    try:
        for listener in listeners:
            assert listener.stderr is not None
            assert listener.stderr.readline().startswith("listening on")
        subjects = {"task.t.1"}
        bid = Bid("t.1", 1, "ghost", 9.0)
        frames = [
            tampered(bid, subjects, 1, (b'"score":9.0', b'"score":NaN')),  # malformed
            tampered(bid, subjects, 2, (b'"score":9.0', b'"score":9.0'), key=None),  # no tag
            tampered(bid, subjects, 3, (b'"score":9.0', b'"score":1e999')),
            tampered(bid, subjects, 4, (b'"attempt":1', b'"attempt":"one"')),
            tampered(bid, subjects, 5, (b'"bidder":"ghost"', b'"bidder":7')),
            tampered(bid, subjects, 6, (b'"score":9.0', b'"score":9.0')),  # valid
        ]
        with MulticastTransport("ghost", time.monotonic, config) as ghost:
            for frame in frames:
                ghost.send_raw(frame)
        outputs = [listener.communicate(timeout=40) for listener in listeners]
    finally:
        for listener in listeners:
            if listener.poll() is None:
                listener.terminate()
            listener.wait(timeout=10)
    assert [listener.returncode for listener in listeners] == [0, 0]
    (json_out, json_err), (text_out, text_err) = outputs

    records = [strict_json(line) for line in json_out.splitlines()]
    assert [r["seq"] for r in records] == [3, 4, 5, 6]
    assert [r.get("invalid", "").split(":")[0] for r in records] == [
        "bad_fields", "bad_fields", "bad_fields", ""]
    assert records[0]["fields"]["score"] == "inf"
    assert "attempt" in records[1]["invalid"] and records[1]["fields"]["attempt"] == "one"
    assert "bidder" in records[2]["invalid"]
    assert records[3]["fields"] == {"task_id": "t.1", "attempt": 1, "bidder": "ghost",
                                    "score": 9.0}

    lines = text_out.splitlines()
    assert len(lines) == 4
    assert all(" INVALID bad_fields: " in line for line in lines[:3])
    assert "INVALID" not in lines[3]

    for err in (json_err, text_err):
        assert 'invalid (shown flagged, rejected by receivers): {"bad_fields": 3}' in err
        dropped = [line for line in err.splitlines() if line.startswith("dropped: ")]
        assert [json.loads(line.removeprefix("dropped: ")) for line in dropped] == [
            {"auth_failed": 1, "malformed": 1}]
