"""The sans-IO decoder: chunking, one byte at a time, errors, fuzzing."""

from __future__ import annotations

import struct
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sibling import load_sibling

from player_server.protocol import (
    NEED_DATA,
    Decoder,
    EncodeError,
    FrameError,
    Message,
    Undecodable,
    encode_message,
)
from player_server.protocol import player_msgs as pm
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.registry import REGISTRY

CASES: list[Any] = list(load_sibling(__file__, "test_protocol_golden.py").CASES)


def all_wire() -> bytes:
    return b"".join(encode_message(i, 0, t, s, body) for _, i, t, s, body, _ in CASES)


def drain(dec: Decoder) -> list[Message | Undecodable]:
    out: list[Message | Undecodable] = []
    while (ev := dec.next_event()) is not NEED_DATA:
        out.append(ev)  # type: ignore[arg-type]
    return out


def test_one_byte_at_a_time() -> None:
    wire = all_wire()
    dec = Decoder()
    got: list[Message | Undecodable] = []
    for i in range(len(wire)):
        dec.feed(wire[i:i + 1])
        got += drain(dec)
    assert [m.body for m in got] == [case[4] for case in CASES]  # type: ignore[union-attr]
    assert dec.buffered == 0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(min_value=1, max_value=300), min_size=1, max_size=40))
def test_arbitrary_chunking(sizes: list[int]) -> None:
    wire = all_wire()
    dec = Decoder()
    got: list[Message | Undecodable] = []
    pos = 0
    k = 0
    while pos < len(wire):
        n = sizes[k % len(sizes)]
        dec.feed(wire[pos:pos + n])
        pos += n
        k += 1
        got += drain(dec)
    assert len(got) == len(CASES)
    assert all(isinstance(m, Message) for m in got)


def test_oversize_frame_is_a_frame_error() -> None:
    dec = Decoder(max_size=1024)
    head = struct.pack(">IIIIIIdII", 0, 0, 4, 0, 2, 1, 0.0, 0, 1025)
    dec.feed(head)
    with pytest.raises(FrameError, match="exceeds the limit"):
        dec.next_event()


def test_bad_body_is_skipped_and_counted() -> None:
    good = encode_message(5, 0, 1, 1, sm.SonarData((1.0,)))
    # counts that differ
    bad = bytearray(good)
    bad[40 + 4:40 + 8] = struct.pack(">I", 2)
    # truncated body (size says 4, struct needs 28)
    short = struct.pack(">IIIIIIdII", 0, 0, 4, 0, 2, 1, 0.0, 0, 4) + b"\0\0\0\0"
    # trailing bytes
    trailing = struct.pack(">IIIIIIdII", 0, 0, 1, 0, 3, 5, 0.0, 0, 8) + b"\0\0\0\2\0\0\0\0"
    # undeclared subtype with a body
    unknown = struct.pack(">IIIIIIdII", 0, 0, 4, 0, 3, 99, 0.0, 0, 4) + b"\0\0\0\0"
    # a body on a message declared empty
    extra = struct.pack(">IIIIIIdII", 0, 0, 1, 0, 3, 4, 0.0, 0, 4) + b"\0\0\0\0"
    dec = Decoder()
    dec.feed(bytes(bad) + short + trailing + unknown + extra + good)
    events = drain(dec)
    assert [type(e).__name__ for e in events] == ["Undecodable"] * 5 + ["Message"]
    assert "differ" in events[0].reason  # type: ignore[union-attr]
    assert "trailing" in events[2].reason  # type: ignore[union-attr]
    assert "no declaration" in events[3].reason  # type: ignore[union-attr]
    assert dec.undecodable == 5 and dec.messages == 1


def test_unknown_message_without_body_decodes_empty() -> None:
    dec = Decoder()
    dec.feed(struct.pack(">IIIIIIdII", 0, 0, 99, 0, 3, 77, 0.0, 0, 0))
    msg = dec.next_event()
    assert isinstance(msg, Message) and msg.body is None


def test_encode_errors_are_clear() -> None:
    with pytest.raises(EncodeError, match="DeviceDatamodeReq"):
        encode_message(1, 0, 3, 5, pm.DeviceDatamodeReq(-1))
    with pytest.raises(EncodeError, match="limit"):
        encode_message(1, 0, 3, 3, pm.DeviceReq(driver_name="x" * 70))
    with pytest.raises(EncodeError):
        encode_message(1, 0, 3, 5, pm.DeviceDatamodeReq("a"))  # type: ignore[arg-type]


def test_counts_above_the_bound_do_not_allocate() -> None:
    head = struct.pack(">IIIIIIdII", 0, 0, 1, 0, 4, 1, 0.0, 0, 8)
    dec = Decoder()
    dec.feed(head + struct.pack(">II", 5000, 5000))  # devlist max is 4096
    ev = dec.next_event()
    assert isinstance(ev, Undecodable) and "limit" in ev.reason


KEYS = sorted(REGISTRY)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(KEYS), st.binary(max_size=200), st.integers(0, 2))
def test_fuzz_bodies_never_raise_unexpectedly(
    key: tuple[int, int, int], body: bytes, trail: int
) -> None:
    interf, mtype, subtype = key
    wire = struct.pack(">IIIIIIdII", 0, 0, interf, 0, mtype, subtype, 0.0, 0, len(body)) + body
    dec = Decoder()
    dec.feed(wire + b"\0" * trail)
    ev = dec.next_event()
    assert isinstance(ev, Message | Undecodable)
    if isinstance(ev, Message) and ev.body is not None:
        # whatever decodes can be encoded again
        assert len(encode_message(interf, 0, mtype, subtype, ev.body)) >= 40


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=400))
def test_fuzz_stream(data: bytes) -> None:
    dec = Decoder(max_size=256)
    dec.feed(data)
    try:
        for _ in range(50):
            if dec.next_event() is NEED_DATA:
                break
    except FrameError:
        pass
