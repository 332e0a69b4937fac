"""Layouts derived from the protocol's declarations (what hand-written readers unpack)."""

from __future__ import annotations

import pytest

from player_server.protocol import actuator_msgs as am
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.codec import encode_payload
from player_server.protocol.xdr import wire_layout


def test_a_fixed_body_unpacks_with_its_layout() -> None:
    body = am.PowerData(1, 12.5, 80.0, 1000.0, 3.5, 1)
    raw = encode_payload(body)
    layout = wire_layout(am.PowerData)
    assert layout.size == len(raw)
    assert am.PowerData(*layout.unpack(raw)) == body


def test_the_head_of_a_counted_array_ends_with_its_two_counts() -> None:
    scan = sm.LaserData(-1.0, 1.0, 0.5, 8.0, (1.0, 2.0, 3.0, 4.0, 5.0), b"", 7)
    head = wire_layout(sm.LaserData, upto="ranges")
    assert head.unpack_from(encode_payload(scan), 0) == (-1.0, 1.0, 0.5, 8.0, 5, 5)


def test_layouts_that_do_not_exist_are_refused() -> None:
    with pytest.raises(TypeError, match="fixed size"):
        wire_layout(sm.LaserData)
    with pytest.raises(TypeError, match="not a counted array"):
        wire_layout(sm.LaserData, upto="max_range")
    with pytest.raises(TypeError, match="no member"):
        wire_layout(am.PowerData, upto="ranges")
