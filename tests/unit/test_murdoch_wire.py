from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, ClassVar

import pytest

from murdoch.auction.messages import (
    AUCTION_CODEC,
    Announce,
    Award,
    Bid,
    Progress,
    Renew,
    Report,
    Revoke,
)
from murdoch.auth import ReplayWindow, TeamKey, strip_tag
from murdoch.transport import EndpointCore
from murdoch.wire import MAX_DATAGRAM_BYTES, Codec, WireError

ANNOUNCE = Announce(
    task_id="user-1.7",
    attempt=1,
    name="sentry-duty",
    subjects=("camera", "laser", "mobile"),
    params={"colour": "red", "where": [1.5, -2.0]},
    duration_s=30.0,
    metrics=(("distance", 1.0), ("battery", 0.5)),
    negotiation="task.user-1.7",
    bid_window_s=0.25,
    renew_period_s=1.0,
    abandon_after_s=3.0,
    parent=None,
)
MESSAGES: list[Any] = [
    ANNOUNCE,
    Bid("user-1.7", 1, "r2", 0.75),
    Award("user-1.7", 1, "r2", 0.75, 3, ""),
    Award("user-1.7", 2, None, None, 0, "no capable agent bid"),
    Renew("user-1.7", 1, "r2", 4),
    Progress("user-1.7", 1, "r2", 0.5, "half way"),
    Report("user-1.7", 1, "r2", "completed", ""),
    Revoke("user-1.7", 1, "r2", "silent"),
]


def frame(obj: dict[str, Any]) -> bytes:
    return json.dumps(obj).encode()


def bid_frame(**overrides: Any) -> dict[str, Any]:
    obj: dict[str, Any] = {
        "v": 1,
        "k": "bid",
        "s": "r2",
        "q": 3,
        "t": ["task.x"],
        "b": {"task_id": "x", "attempt": 1, "bidder": "r2", "score": 1.0},
    }
    obj.update(overrides)
    return frame(obj)


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.KIND)
def test_every_auction_message_round_trips(message: Any) -> None:
    data = AUCTION_CODEC.encode_frame("r2", 5, frozenset({"task.user-1.7"}), message)
    assert len(data) < 600
    parsed = AUCTION_CODEC.parse_frame(data)
    assert (parsed.kind, parsed.sender, parsed.seq) == (message.KIND, "r2", 5)
    assert parsed.subjects == frozenset({"task.user-1.7"})
    assert AUCTION_CODEC.message_of(parsed) == message


def test_wire_layout_is_the_documented_one() -> None:
    data = AUCTION_CODEC.encode_frame(
        "r2", 9, frozenset({"b", "a"}), Bid("t", 1, "r2", 2.5), instance="5e1f"
    )
    assert json.loads(data) == {
        "v": 1,
        "k": "bid",
        "s": "r2",
        "i": "5e1f",
        "q": 9,
        "t": ["a", "b"],
        "b": {"task_id": "t", "attempt": 1, "bidder": "r2", "score": 2.5},
    }


def test_decoded_params_are_read_only_and_lists_become_tuples() -> None:
    data = AUCTION_CODEC.encode_frame("u", 0, frozenset(), ANNOUNCE)
    message = AUCTION_CODEC.message_of(AUCTION_CODEC.parse_frame(data))
    assert message.params["where"] == (1.5, -2.0)
    with pytest.raises(TypeError):
        message.params["colour"] = "blue"


BAD = [
    (b"\xff\xfe", "malformed"),
    (b"not json", "malformed"),
    (b"[1, 2]", "malformed"),
    (frame({"v": 2, "k": "bid"}), "bad_version"),
    (bid_frame(q=-1), "malformed"),
    (bid_frame(q=True), "malformed"),
    (bid_frame(s=""), "malformed"),
    (bid_frame(i=7), "malformed"),
    (bid_frame(t=["Not A Subject"]), "malformed"),
    (bid_frame(t="task.x"), "malformed"),
    (bid_frame(k="mystery"), "unknown_kind"),
    (bid_frame(b={"task_id": "x"}), "bad_fields"),
    (bid_frame(b={"task_id": "x", "attempt": "1", "bidder": "r2", "score": 1.0}), "bad_fields"),
    (bid_frame(b={"task_id": "x", "attempt": 1, "bidder": "r2", "score": True}), "bad_fields"),
    (b'{"v":1,"k":"bid","s":"r","q":1,"t":[],"b":{"task_id":"x","attempt":1,'
     b'"bidder":"r","score":NaN}}', "malformed"),
    (b"{" + b" " * MAX_DATAGRAM_BYTES + b"}", "too_large"),
]


@pytest.mark.parametrize(("data", "reason"), BAD)
def test_bad_datagrams_are_dropped_and_counted_by_reason(data: bytes, reason: str) -> None:
    core = EndpointCore("me", AUCTION_CODEC, clock=lambda: 0.0)
    sub = core.subscribe(None)
    assert core.receive(data) == 0
    assert core.counters.dropped == {reason: 1}
    assert sub.drain() == []
    # the endpoint still works afterwards
    assert core.receive(bid_frame()) == 1


def test_oversized_messages_are_refused_when_encoding() -> None:
    big = Progress("t", 1, "r", 0.1, "x" * 2000)
    with pytest.raises(WireError) as info:
        AUCTION_CODEC.encode_frame("r", 0, frozenset(), big)
    assert info.value.reason == "too_large"


def test_other_packages_add_kinds_with_their_own_codec() -> None:
    @dataclass(frozen=True)
    class Ping:
        KIND: ClassVar[str] = "ping"
        n: int
        tags: tuple[str, ...]

    codec = AUCTION_CODEC.extended([Ping])
    data = codec.encode_frame("a", 0, frozenset(), Ping(3, ("x", "y")))
    assert codec.message_of(codec.parse_frame(data)) == Ping(3, ("x", "y"))
    with pytest.raises(WireError):
        AUCTION_CODEC.message_of(AUCTION_CODEC.parse_frame(data))
    with pytest.raises(TypeError, match="share the kind"):
        Codec([Bid, type("Other", (Ping,), {"KIND": "bid"})])


def test_signed_datagrams_verify_and_any_change_is_caught() -> None:
    key = TeamKey("team-secret-1")
    plain = AUCTION_CODEC.encode_frame("r2", 1, frozenset({"task.x"}), Bid("x", 1, "r2", 1.0))
    signed = key.sign(plain)
    assert json.loads(signed)["h"]  # still one JSON object
    assert key.verify(signed) == plain
    assert strip_tag(signed) == plain
    tampered = signed.replace(b'"score":1.0', b'"score":9.0')
    with pytest.raises(WireError, match="auth_failed"):
        key.verify(tampered)
    with pytest.raises(WireError, match="auth_failed"):
        TeamKey("another-key").verify(signed)
    with pytest.raises(WireError, match="auth_failed"):
        key.verify(plain)


def test_replay_window_accepts_each_number_once_and_forgets_old_ones() -> None:
    window = ReplayWindow(window=8, max_senders=2)
    assert [window.accept("a", n) for n in (0, 2, 1, 2, 0)] == [True, True, True, False, False]
    assert window.accept("a", 20)
    assert not window.accept("a", 12)  # older than the window
    assert window.accept("a", 13)
    assert not window.accept("a", 13)
    assert window.accept("b", 0) and window.accept("c", 0)  # evicts "a"
    assert window.accept("a", 20)  # a forgotten sender starts afresh


def test_keyed_endpoint_rejects_unsigned_forged_and_replayed_datagrams() -> None:
    key = TeamKey("team-secret-1")
    sender = EndpointCore("r2", AUCTION_CODEC, lambda: 0.0, key=key)
    receiver = EndpointCore("me", AUCTION_CODEC, lambda: 0.0, key=key)
    sub = receiver.subscribe({"task.x"})
    good = sender.encode({"task.x"}, Bid("x", 1, "r2", 1.0))
    forged = TeamKey("guessed-key").sign(
        AUCTION_CODEC.encode_frame("r2", 1, frozenset({"task.x"}), Bid("x", 1, "r2", 99.0))
    )
    unsigned = AUCTION_CODEC.encode_frame("r2", 2, frozenset({"task.x"}), Bid("x", 1, "r2", 5.0))
    for data in (good, forged, unsigned, good):
        receiver.receive(data)
    assert [e.message.score for e in sub.drain()] == [1.0]
    assert receiver.counters.dropped == {"auth_failed": 2, "replayed": 1}


def test_a_restarted_sender_is_a_new_instance_for_the_replay_window() -> None:
    key = TeamKey("team-secret-1")
    receiver = EndpointCore("me", AUCTION_CODEC, lambda: 0.0, key=key)
    sub = receiver.subscribe({"task.x"})
    for run in ("aaaa", "bbbb"):  # the same robot name, before and after a restart
        sender = EndpointCore("r2", AUCTION_CODEC, lambda: 0.0, key=key, instance=run)
        receiver.receive(sender.encode({"task.x"}, Bid("x", 1, "r2", 1.0)))
    assert len(sub.drain()) == 2 and receiver.counters.dropped == {}
