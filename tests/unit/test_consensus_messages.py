"""The consensus message encoding."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus.messages import (
    KIND_CBBA,
    KIND_CBGA,
    ConsensusMessage,
    MessageError,
    decode,
    encode,
    encoded_size,
)

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=50, deadline=None, derandomize=True)
@given(st.sampled_from([KIND_CBBA, KIND_CBGA]), st.integers(0, 65535), finite,
       st.lists(st.tuples(st.integers(0, 65535), st.integers(0, 65535), finite), max_size=20),
       st.lists(st.one_of(finite, st.just(float("-inf"))), max_size=12))
def test_round_trip_and_size(kind, sender, time, entries, stamps) -> None:
    msg = ConsensusMessage(kind, sender, time, tuple(entries), tuple(stamps))
    data = encode(msg)
    assert len(data) == encoded_size(len(entries), len(stamps))
    assert decode(data) == msg


@pytest.mark.parametrize("data", [b"", b"\x01\x00", b"\x09" + bytes(14),
                                  encode(ConsensusMessage(1, 0, 0.0, ((1, 2, 3.0),), ()))[:-1]])
def test_malformed_messages_are_rejected(data: bytes) -> None:
    with pytest.raises(MessageError):
        decode(data)
