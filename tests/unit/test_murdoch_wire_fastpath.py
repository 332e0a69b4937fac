"""The compact-form readers and writers of scalar-only messages agree with the JSON path."""

from __future__ import annotations

import json
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.auction.messages import (
    AUCTION_CODEC,
    Announce,
    Award,
    Bid,
    Progress,
    Report,
    Revoke,
)
from murdoch.transport import EndpointCore

TEXT = st.text(max_size=12)  # any code point: quotes, backslashes, controls, non-ASCII
FINITE = st.floats(allow_nan=False, allow_infinity=False)
RAW_TOKENS = st.one_of(
    st.sampled_from([
        b"0", b"-0", b"1", b"17", b"-3", b"1.5", b"-0.0", b"1e3", b"2E-2", b"1e999", b"-1e999",
        b"1" + b"0" * 400, b"01", b"1.", b".5", b"+1", b"NaN", b"Infinity", b"null", b"true",
        b"false", b'""', b'"r2"', b'"a\\"b"', b'"\\u00e9"', b'"\\ud800"', b'"\xc3\xa9"',
        b'"\xed\xa0\x80"', b'"\xff"', b'"tab\there"', b"[]", b"{}", b'"x"', b"1.0",
    ]),
    st.integers(-(10**25), 10**25).map(lambda n: str(n).encode()),
    FINITE.map(lambda x: json.dumps(x).encode()),
    TEXT.map(lambda t: json.dumps(t, ensure_ascii=False).encode("utf-8", "surrogatepass")),
)


CONTAINER_TOKENS = st.sampled_from([
    b"[]", b'["camera"]', b'["camera","laser"]', b'[""]', b'["a\\"b"]', b'["\xff"]', b"[1]",
    b'["a",]', b'[ "a"]', b"{}", b'{"k":1}', b'{"k":[1,2]}', b'[["d",1.0]]', b"[[]]", b"{ }",
])
ANNOUNCE_FIELDS = {
    "task_id": b'"x.1"', "attempt": b"1", "name": b'"bench"', "subjects": b'["camera"]',
    "params": b"{}", "duration_s": b"0.0", "metrics": b"[]", "negotiation": b'"task.x.1"',
    "bid_window_s": b"0.02", "renew_period_s": b"1.0", "abandon_after_s": b"3.0",
    "parent": b"null",
}


def outcome(data: bytes) -> tuple[list[Any], dict[str, int]]:
    core = EndpointCore("me", AUCTION_CODEC, clock=lambda: 0.0)
    sub = core.subscribe(None)
    core.receive(data)
    messages = [e.message for e in sub.drain()]
    return [(m, [type(getattr(m, f)) for f in vars(m)]) for m in messages], core.counters.dropped


@settings(max_examples=300, deadline=None)
@given(kind=st.sampled_from(["bid", "award", "report", "progress"]),
       tokens=st.lists(RAW_TOKENS, min_size=6, max_size=6))
def test_compact_bodies_decode_as_the_json_decoder_decodes_them(
    kind: str, tokens: list[bytes]
) -> None:
    names = {"bid": ["task_id", "attempt", "bidder", "score"],
             "award": ["task_id", "attempt", "winner", "score", "bids", "reason"],
             "report": ["task_id", "attempt", "winner", "status", "reason"],
             "progress": ["task_id", "attempt", "winner", "fraction", "note"]}[kind]
    members = [b'"%s":%s' % (n.encode(), t) for n, t in zip(names, tokens, strict=False)]
    body = b"{" + b",".join(members) + b"}"
    compact = b'{"h":[3,"%s","r2","",3,"task.x",-1,""],"b":%s}' % (kind.encode(), body)
    spaced = b'{ "h":[3,"%s","r2","",3,"task.x",-1,""],"b":%s}' % (kind.encode(), body)
    assert outcome(compact) == outcome(spaced)  # the spaced one is decoded whole, as JSON


@settings(max_examples=200, deadline=None)
@given(task=TEXT, bidder=TEXT, attempt=st.integers(0, 2**70), score=FINITE,
       winner=st.none() | TEXT, maybe=st.none() | FINITE)
def test_compact_bodies_are_written_as_the_json_encoder_writes_them(
    task: str, bidder: str, attempt: int, score: float, winner: str | None,
    maybe: float | None,
) -> None:
    encoder = json.JSONEncoder(separators=(",", ":"), allow_nan=False)
    for message in (Bid(task, attempt, bidder, score),
                    Award(task, attempt, winner, maybe, attempt, bidder),
                    Report(task, attempt, bidder, "failed", task),
                    Progress(task, attempt, bidder, score, task),
                    Revoke(task, attempt, bidder, bidder),
                    Announce(task, attempt, bidder, (task, bidder), {}, abs(score), (),
                             "task.x", 0.5, 1.0, 3.0, winner),
                    Announce(task, attempt, bidder, (), {"k": [task]}, 0.0, (("d", score),),
                             "task.x", 0.5, 1.0, 3.0, None)):
        data = AUCTION_CODEC.encode_frame("r2", 1, frozenset({"task.x"}), message)
        body = data[data.index(b',"b":') + 5 : -1]
        assert body == encoder.encode(AUCTION_CODEC.body_of(message)).encode()
        header = AUCTION_CODEC.parse_header(data)
        assert AUCTION_CODEC.decode_message(data, header) == message
        assert AUCTION_CODEC.message_from(
            message.KIND, AUCTION_CODEC.decode_body(data, header)) == message


def test_an_integer_too_large_for_a_float_field_is_a_bad_field_not_a_crash() -> None:
    data = b'{"h":[3,"bid","r2","",3,"task.x",-1,""],"b":{"task_id":"x","attempt":1,' \
           b'"bidder":"r2","score":1' + b"0" * 400 + b"}}"
    assert outcome(data) == ([], {"bad_fields": 1})


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_compact_announcements_decode_as_the_json_decoder_decodes_them(
    data: st.DataObject,
) -> None:
    members = []
    for name, usual in ANNOUNCE_FIELDS.items():
        odd = st.one_of(CONTAINER_TOKENS, RAW_TOKENS)
        token = data.draw(st.one_of(*[st.just(usual)] * 6, odd))  # mostly usual ones
        members.append(b'"%s":%s' % (name.encode(), token))
    body = b"{" + b",".join(members) + b"}"
    compact = b'{"h":[3,"announce","u","",3,"camera,idle",-1,""],"b":%s}' % body
    spaced = b'{ "h":[3,"announce","u","",3,"camera,idle",-1,""],"b":%s}' % body
    assert outcome(compact) == outcome(spaced)


def test_a_usual_announcement_is_read_by_the_compact_path_and_equals_the_json_one() -> None:
    for subjects in (b"[]", b'["camera"]', b'["mobile","camera","laser"]'):
        fields = {**ANNOUNCE_FIELDS, "subjects": subjects}
        members = [b'"%s":%s' % (n.encode(), t) for n, t in fields.items()]
        body = b"{" + b",".join(members) + b"}"
        data = b'{"h":[3,"announce","u","",3,"camera,idle",-1,""],"b":%s}' % body
        header = AUCTION_CODEC.parse_header(data)
        fast = AUCTION_CODEC.decode_message(data, header)
        assert fast == AUCTION_CODEC.message_from("announce", json.loads(body))
        assert fast.subjects == tuple(json.loads(subjects))
        assert dict(fast.params) == {} and fast.metrics == ()
