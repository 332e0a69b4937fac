from __future__ import annotations

import hmac
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
from murdoch.subjects import SubjectError
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


BID_BODY = {"task_id": "x", "attempt": 1, "bidder": "r2", "score": 1.0}


def bid_frame(header: str = '3,"bid","r2","",3,"task.x",-1,""', body: Any = None) -> bytes:
    """A hand-made datagram of the standard shape (a valid bid unless overridden)."""
    if body is None:
        body = BID_BODY
    raw = body if isinstance(body, bytes) else json.dumps(body, separators=(",", ":")).encode()
    return b'{"h":[' + header.encode() + b'],"b":' + raw + b"}"


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
    assert data == (b'{"h":[3,"bid","r2","5e1f",9,"a,b",-1,""],'
                    b'"b":{"task_id":"t","attempt":1,"bidder":"r2","score":2.5}}')
    assert json.loads(data) == {  # one JSON value, whole
        "h": [3, "bid", "r2", "5e1f", 9, "a,b", -1, ""],
        "b": {"task_id": "t", "attempt": 1, "bidder": "r2", "score": 2.5},
    }
    empty = AUCTION_CODEC.encode_frame("r2", 0, frozenset(), Renew("t", 1, "r2", 1))
    assert empty.startswith(b'{"h":[3,"renew","r2","",0,"",-1,""],"b":{')
    assert AUCTION_CODEC.parse_header(empty).subjects == frozenset()


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.KIND)
def test_every_datagram_is_one_json_object_signed_or_not(message: Any) -> None:
    plain = AUCTION_CODEC.encode_frame("r2", 5, frozenset({"task.user-1.7", "idle"}), message,
                                       instance="ab12")
    signed = TeamKey("team-secret-1").sign(plain)
    for data in (plain, signed):
        obj = json.loads(data)
        assert obj["h"] == [3, message.KIND, "r2", "ab12", 5, "idle,task.user-1.7", -1, ""]
        assert obj["b"] == AUCTION_CODEC.body_of(message)
        # the header-first reading and a whole decode of another layout agree
        relaid = json.dumps(obj, indent=1, sort_keys=True).encode()
        assert AUCTION_CODEC.parse_frame(relaid) == AUCTION_CODEC.parse_frame(data)
        assert AUCTION_CODEC.parse_header(data).body is None  # standard shape: body unread
        assert AUCTION_CODEC.parse_header(relaid).body is not None  # decoded whole
    assert set(json.loads(signed)) == {"h", "b", "mac"}


def test_header_alone_gives_addressing_without_the_body() -> None:
    data = AUCTION_CODEC.encode_frame("r2", 7, frozenset({"task.x"}), Bid("x", 1, "r2", 1.0),
                                      instance="ab12")
    header = AUCTION_CODEC.parse_header(data)
    assert header[:5] == ("bid", "r2", "ab12", 7, frozenset({"task.x"}))
    assert header.body is None  # not decoded yet
    assert json.loads(data[header.body_at:header.body_end]) == AUCTION_CODEC.body_of(
        Bid("x", 1, "r2", 1.0))
    replies = {k for k in AUCTION_CODEC.kinds if AUCTION_CODEC.is_reply(k)}
    assert replies == {"bid", "award", "progress", "report"}


def test_other_json_layouts_of_a_datagram_are_accepted() -> None:
    """Valid JSON that does not have the standard shape is decoded whole, same result."""
    core = EndpointCore("me", AUCTION_CODEC, clock=lambda: 0.0)
    sub = core.subscribe({"task.x"})
    obj = {"h": [3, "bid", "r2", "", 3, "task.x", -1, ""], "b": BID_BODY}
    variants = [
        json.dumps(obj).encode(),  # spaces
        json.dumps(obj, indent=2).encode(),
        json.dumps({"b": BID_BODY, "h": obj["h"]}).encode(),  # body first
        b'{"h":[3,"bid","r\\u0032","",3,"task.x",-1,""],"b":{"task_id":"x","attempt":1,'
        b'"bidder":"r2","score":1.0}}',  # an escaped header token
        b'{"h":[3,"bid","r2","",3,"task.x",-1,""],"b":{"task_id":"x","attempt":1,'
        b'"bidder":"r2","score":1.0},"mac":"not checked without a key"}',
    ]
    for n, data in enumerate(variants):
        assert core.receive(data) == 1, (n, core.counters.dropped)
    assert [e.message for e in sub.drain()] == [Bid("x", 1, "r2", 1.0)] * len(variants)
    assert core.counters.dropped == {}


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
    (b"", "malformed"),
    (frame({"v": 1, "k": "bid"}), "bad_version"),  # version 1
    (b"M2 bid r2 - 3 task.x\n{}", "malformed"),
    (bid_frame('2,"bid","r2","",3,"task.x"'), "bad_version"),
    (bid_frame('"2","bid","r2","",3,"task.x"'), "malformed"),
    (bid_frame('3,"bid","r2","",-1,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","","3","task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","",3.0,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","","",3,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","r 2","",3,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","",3'), "malformed"),
    (bid_frame('3,"bid","r2","",3,"task.x",-1,"","extra"'), "malformed"),
    (bid_frame('3,"bid","r2","",3,"task.x",-2,""'), "malformed"),  # tick below -1
    (bid_frame('3,"bid","r2","",3,"task.x",1.5,""'), "malformed"),  # tick not an int
    (bid_frame('3,"bid","r2","",3,"task.x",9007199254740992,""'), "malformed"),  # tick too big
    (bid_frame('3,"bid","r2","",3,"task.x",-1,"e 1"'), "malformed"),  # epoch not a token
    (bid_frame('3,"bid","r2","",3,"task.x",-1,7'), "malformed"),  # epoch not a string
    (bid_frame('3,"bid","r\\u0001","",3,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"Bid!","r2","",3,"task.x",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","",3,"Not_A_Subject",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","",3,"task.x,,y",-1,""'), "malformed"),
    (bid_frame('3,"bid","r2","",3,["task.x"],-1,""'), "malformed"),
    (bid_frame('3,"bid",["r2"],"",3,"task.x",-1,""'), "malformed"),
    (b'{"h":[3,"bid","r2","",3,"task.x",-1,""]}', "malformed"),  # no body
    (b'{"h":[3,"bid","r2","",3,"task.x",-1,""],"b":{}', "malformed"),  # cut short
    (b'{"h":[3,"bid","r2","",3,"task.x",-1,""],"b":{},"x":1}', "malformed"),  # extra member
    (b'{"h":[3,"bid","r2","",3,"task.x",-1,""],"b":{},"h":[3,"bid","r2","",3,"task.x",-1,""]}',
     "malformed"),  # repeated member
    (bid_frame(body=b'{"task_id":"x","task_id":"y","attempt":1,"bidder":"r2","score":1}'),
     "malformed"),
    (bid_frame(body=b"[1]"), "malformed"),
    (bid_frame(body=b"{not json"), "malformed"),
    (bid_frame(body=b"\xff"), "malformed"),
    (bid_frame('3,"mystery","r2","",3,"task.x",-1,""'), "unknown_kind"),
    (bid_frame(body={"task_id": "x"}), "bad_fields"),
    (bid_frame(body={"task_id": "x", "attempt": "1", "bidder": "r2", "score": 1.0}), "bad_fields"),
    (bid_frame(body={"task_id": "x", "attempt": 1, "bidder": "r2", "score": True}), "bad_fields"),
    (bid_frame(body=b'{"task_id":"x","attempt":1,"bidder":"r","score":NaN}'), "malformed"),
    (bid_frame(body=b"{" + b" " * MAX_DATAGRAM_BYTES + b"}"), "too_large"),
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
    covered, tag = signed[:-74], signed[-74:]
    assert covered == plain[:-1] and tag.startswith(b',"mac":"') and tag.endswith(b'"}')
    assert json.loads(signed)["mac"] == hmac.new(b"team-secret-1", covered, "sha256").hexdigest()
    assert key.verify(signed) == plain
    assert strip_tag(signed) == plain and strip_tag(plain) == plain
    tampered = signed.replace(b'"score":1.0', b'"score":9.0')
    with pytest.raises(WireError, match="auth_failed"):
        key.verify(tampered)
    with pytest.raises(WireError, match="auth_failed"):
        TeamKey("another-key").verify(signed)
    with pytest.raises(WireError, match="auth_failed"):
        key.verify(plain)
    with pytest.raises(ValueError, match="unsigned"):
        key.sign(signed)


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


def test_unmatched_datagrams_are_dropped_before_the_body_is_read() -> None:
    """Nobody listens to task.y here: even a body that is not JSON only counts as unmatched."""
    core = EndpointCore("me", AUCTION_CODEC, clock=lambda: 0.0)
    sub = core.subscribe({"task.x", "camera", "idle"})
    assert core.receive(bid_frame('3,"bid","r2","",3,"task.y",-1,""', body=b"{broken")) == 0
    assert core.counters.dropped == {"unmatched": 1}
    assert core.counters.received("bid") == 1
    # what the subscription covers is still decoded, checked and delivered
    assert core.receive(bid_frame('3,"bid","r2","",4,"task.x",-1,""', body=b"{broken")) == 0
    assert core.counters.dropped == {"unmatched": 1, "malformed": 1}
    assert core.receive(bid_frame('3,"bid","r2","",5,"task.x",-1,""')) == 1
    assert [e.seq for e in sub.drain()] == [5]
    # an unknown kind is an error even when nobody would have listened
    assert core.receive(bid_frame('3,"mystery","r2","",6,"task.y",-1,""')) == 0
    assert core.counters.dropped["unknown_kind"] == 1
    # changing the subscription changes the filter at once (no stale cached match)
    sub.update({"task.y"})
    assert core.receive(bid_frame('3,"bid","r2","",7,"task.y",-1,""')) == 1
    assert core.receive(bid_frame('3,"bid","r2","",8,"task.x",-1,""')) == 0
    sub.close()
    assert core.receive(bid_frame('3,"bid","r2","",9,"task.y",-1,""')) == 0


def test_keyed_endpoint_authenticates_what_it_acts_on_and_skips_the_rest() -> None:
    key = TeamKey("team-secret-1")
    receiver = EndpointCore("me", AUCTION_CODEC, lambda: 0.0, key=key)
    sub = receiver.subscribe({"task.x"})
    forged_elsewhere = TeamKey("guessed-key").sign(
        AUCTION_CODEC.encode_frame("r2", 1, frozenset({"task.y"}), Bid("y", 1, "r2", 1.0)))
    receiver.receive(forged_elsewhere)  # not for us: dropped unread
    assert receiver.counters.dropped == {"unmatched": 1}
    tampered_header = key.sign(
        AUCTION_CODEC.encode_frame("r2", 2, frozenset({"task.y"}), Bid("x", 1, "r2", 1.0))
    ).replace(b"task.y", b"task.x")
    receiver.receive(tampered_header)  # readdressed to us: the tag covers the header too
    assert receiver.counters.dropped == {"unmatched": 1, "auth_failed": 1}
    good = key.sign(AUCTION_CODEC.encode_frame("r2", 3, frozenset({"task.x"}),
                                               Bid("x", 1, "r2", 1.0)))
    moved = json.loads(good)  # the same members re-laid out: the tag no longer ends it
    relaid = json.dumps({"mac": moved["mac"], "h": moved["h"], "b": moved["b"]}).encode()
    receiver.receive(relaid)
    assert receiver.counters.dropped == {"unmatched": 1, "auth_failed": 2}
    assert sub.drain() == []
    receiver.receive(good)
    assert [e.seq for e in sub.drain()] == [3]


def test_header_tokens_are_checked_when_encoding() -> None:
    for bad in ("r 2", 'r"2', "r]2", "r[2", "r\\2", "", "é"):
        with pytest.raises(ValueError, match="sender"):
            AUCTION_CODEC.encode_frame(bad, 0, frozenset(), Bid("x", 1, "r2", 1.0))
    with pytest.raises(ValueError, match="instance"):
        AUCTION_CODEC.encode_frame("r2", 0, frozenset(), Bid("x", 1, "r2", 1.0), instance="a]")
    with pytest.raises(SubjectError):
        AUCTION_CODEC.encode_frame("r2", 0, frozenset({"Task]"}), Bid("x", 1, "r2", 1.0))
    with pytest.raises(ValueError, match="sender_id"):
        EndpointCore("two words", AUCTION_CODEC, lambda: 0.0)

    @dataclass(frozen=True)
    class Odd:
        KIND: ClassVar[str] = "has space"

    with pytest.raises(TypeError, match="KIND"):
        Codec([Odd])
