"""The fast decoding paths give exactly what the plain ones give.

* bodies of every declared class, generated from their wire specs, survive
  encode -> decode (the compiled codecs inline counted arrays and struct arrays);
* ``Decoder.events`` (one pass, bodies decoded in place in the stream buffer) yields the
  same messages as ``next_event`` and as decoding each body on its own with
  ``decode_body``, for any chunking, and the same events and frame errors for garbage.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from player_server.protocol import NEED_DATA, Decoder, Message, Undecodable, encode_message
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.errors import FrameError
from player_server.protocol.header import HEADER_STRUCT
from player_server.protocol.registry import REGISTRY
from player_server.protocol.xdr import Array, Bytes, Scalar, String, decode_body, encode_body

_SCALARS: dict[str, st.SearchStrategy[Any]] = {
    "I": st.integers(0, 2**32 - 1),
    "i": st.integers(-(2**31), 2**31 - 1),
    "q": st.integers(-(2**63), 2**63 - 1),
    "f": st.floats(width=32, allow_nan=False),
    "d": st.floats(allow_nan=False),
}


def _strategy(spec: Any) -> st.SearchStrategy[Any]:
    if isinstance(spec, Scalar):
        return _SCALARS[spec.code]
    if isinstance(spec, Array):
        limit = min(spec.max_count if spec.max_count is not None else 6, 6)
        return st.lists(_strategy(spec.elem), max_size=limit).map(tuple)
    if isinstance(spec, Bytes):
        return st.binary(max_size=min(spec.max_count or 13, 13))
    if isinstance(spec, String):
        limit = (spec.max_count or 12) - 1
        return st.text(st.characters(min_codepoint=1, max_codepoint=0x7F), max_size=limit)
    return st.builds(spec, *(_strategy(sub) for _, sub in spec.XDR_SPECS))


BODY_KEYS = sorted(k for k, cls in REGISTRY.items() if cls is not None)


@st.composite
def messages(draw: st.DrawFn) -> tuple[tuple[int, int, int], Any]:
    key = draw(st.sampled_from(BODY_KEYS))
    return key, draw(_strategy(REGISTRY[key]))


@settings(max_examples=150, deadline=None)
@given(messages())
def test_every_body_round_trips(msg: tuple[tuple[int, int, int], Any]) -> None:
    (_, _, _), body = msg
    wire = encode_body(body)
    assert decode_body(type(body), wire) == body
    assert decode_body(type(body), memoryview(bytearray(wire))) == body


def _drain_next(dec: Decoder) -> list[Any]:
    out: list[Any] = []
    while (ev := dec.next_event()) is not NEED_DATA:
        out.append(ev)
    return out


@settings(max_examples=80, deadline=None)
@given(st.lists(messages(), min_size=1, max_size=8),
       st.lists(st.integers(1, 97), min_size=1, max_size=10))
def test_events_equal_next_event_and_plain_decoding(
    msgs: list[tuple[tuple[int, int, int], Any]], chunks: list[int]
) -> None:
    wire = b"".join(encode_message(i, 0, t, s, body, timestamp=0.5) for (i, t, s), body in msgs)
    fast, slow = Decoder(), Decoder()
    got_fast: list[Any] = []
    got_slow: list[Any] = []
    pos = k = 0
    while pos < len(wire):
        n = chunks[k % len(chunks)]
        fast.feed(wire[pos:pos + n])
        slow.feed(memoryview(wire)[pos:pos + n])
        pos += n
        k += 1
        got_fast += fast.events()
        got_slow += _drain_next(slow)
    assert got_fast == got_slow
    assert [m.body for m in got_fast] == [body for _, body in msgs]
    # the plain path: each body on its own, as an exact-size bytes object
    off = 0
    for m in got_fast:
        assert isinstance(m, Message)
        size = m.header.size
        body = wire[off + 40:off + 40 + size]
        assert decode_body(type(m.body), body) == m.body
        off += 40 + size
    assert fast.messages == slow.messages == len(msgs) and fast.buffered == 0


def _events_until_error(dec: Decoder, use_events: bool) -> tuple[list[str], str]:
    out: list[str] = []
    try:
        for _ in range(100):
            if use_events:
                evs = dec.events()
                if not evs:
                    break
                out += [repr(e) for e in evs]
            else:
                ev = dec.next_event()
                if ev is NEED_DATA:
                    break
                out.append(repr(ev))
    except FrameError as exc:
        return out, str(exc)
    return out, ""


@settings(max_examples=120, deadline=None)
@given(st.lists(st.one_of(
    st.binary(max_size=60),
    messages().map(lambda m: encode_message(m[0][0], 0, m[0][1], m[0][2], m[1])),
    st.tuples(st.sampled_from(BODY_KEYS), st.binary(max_size=64)).map(
        lambda kb: HEADER_STRUCT.pack(0, 0, kb[0][0], 0, kb[0][1], kb[0][2], 0.0, 0,
                                      len(kb[1])) + kb[1]),
), max_size=6))
def test_garbage_gives_the_same_events_and_frame_errors(parts: list[bytes]) -> None:
    data = b"".join(parts)
    a, b = Decoder(max_size=300), Decoder(max_size=300)
    a.feed(data)
    b.feed(data)
    assert _events_until_error(a, True) == _events_until_error(b, False)
    assert (a.messages, a.undecodable) == (b.messages, b.undecodable)


def test_frame_error_comes_after_the_messages_before_it() -> None:
    good = encode_message(5, 0, 1, 1, sm.SonarData((1.0,)))
    huge = HEADER_STRUCT.pack(0, 0, 5, 0, 1, 1, 0.0, 0, 10_000)
    dec = Decoder(max_size=1000)
    dec.feed(good + good + huge)
    assert [m.body for m in dec.events()] == [sm.SonarData((1.0,))] * 2
    with pytest.raises(FrameError, match="exceeds the limit"):
        dec.events()


def test_bad_bodies_in_place_are_skipped_with_their_class_named() -> None:
    blob = sm.BlobfinderBlob(1, 0xFF0000, 10, 2, 3, 1, 4, 2, 5, 1.5)
    full = encode_message(7, 0, 1, 1, sm.BlobfinderData(80, 60, (blob, blob)))
    # claim two blobs but carry one: the second would be read from the next frame
    body = full[40:]
    short = body[:-40]
    bad = HEADER_STRUCT.pack(0, 0, 7, 0, 1, 1, 0.0, 0, len(short)) + short
    trailing = HEADER_STRUCT.pack(0, 0, 7, 0, 1, 1, 0.0, 0, len(body) + 4) + body + b"\0" * 4
    dec = Decoder()
    dec.feed(bad + full + trailing + full)
    evs = dec.events()
    assert [type(e) for e in evs] == [Undecodable, Message, Undecodable, Message]
    assert "BlobfinderData" in evs[0].reason and "past" in evs[0].reason  # type: ignore[union-attr]
    assert evs[0].raw_body == short  # type: ignore[union-attr]
    assert "trailing" in evs[2].reason  # type: ignore[union-attr]
    assert evs[1].body == evs[3].body == sm.BlobfinderData(80, 60, (blob, blob))  # type: ignore[union-attr]
    # a truncated array at the very end of the buffer is a struct error, also skipped
    dec2 = Decoder()
    dec2.feed(HEADER_STRUCT.pack(0, 0, 5, 0, 1, 1, 0.0, 0, 12) + struct.pack(">IIf", 9, 9, 1.0))
    (ev,) = dec2.events()
    assert isinstance(ev, Undecodable) and ev.reason.startswith("SonarData:")


def test_special_floats_survive() -> None:
    body = sm.LaserData(-1.5, 1.5, 0.25, 8.0, (math.inf, 0.0, -0.0, 2.0**-140), b"\x01\x02\x03\x04",
                        7)
    dec = Decoder()
    dec.feed(encode_message(6, 0, 1, 1, body) + encode_message(6, 0, 1, 1, sm.LaserData(
        0, 0, 0, 0, (math.nan,), b"", 0)))
    first, second = dec.events()
    assert first.body == body  # type: ignore[union-attr]
    assert math.isnan(second.body.ranges[0])  # type: ignore[union-attr]
