"""A proxy decodes a DATA body once while the same bytes keep coming (pure logic: the
bytes are handed to the proxy as the client's receive buffer holds them)."""

from __future__ import annotations

from typing import Any

import pytest

from player_server.client import OpaqueProxy, PtzProxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.codec import encode_payload
from player_server.protocol.errors import DecodeError


def _feed(proxy: Any, subtype: int, body: bytes, t: float) -> None:
    buf = bytearray(b"\xee" * 8 + body + b"\xee" * 8)  # the body amid other frames
    proxy._on_raw(subtype, buf, 8, 8 + len(body), t)


def test_the_same_bytes_give_the_same_body_and_new_bytes_a_new_one() -> None:
    ptz = PtzProxy(None)
    still = encode_payload(am.PtzData(0.5, 0.1, 1.0, 0.0, 0.0, 0))
    _feed(ptz, c.PLAYER_PTZ_DATA_STATE, still, 1.0)
    first = ptz.state
    _feed(ptz, c.PLAYER_PTZ_DATA_STATE, still, 1.1)
    assert ptz.state is first and ptz.data_count == 2 and ptz.data_time_s == 1.1
    _feed(ptz, c.PLAYER_PTZ_DATA_STATE, encode_payload(am.PtzData(0.6, 0.1, 1.0)), 1.2)
    assert ptz.state is not first and ptz.pan == pytest.approx(0.6)
    _feed(ptz, c.PLAYER_PTZ_DATA_STATE, still, 1.3)  # back to the first bytes: decoded again
    assert ptz.state == first and ptz.pan == pytest.approx(0.5)


def test_bytes_that_do_not_decode_are_refused_every_time_and_change_nothing() -> None:
    opaque = OpaqueProxy(None)
    table = encode_payload(sm.OpaqueData(b"counts"))
    _feed(opaque, c.PLAYER_OPAQUE_DATA_STATE, table, 1.0)
    broken = table[:3]
    for _ in range(2):
        with pytest.raises(DecodeError):
            _feed(opaque, c.PLAYER_OPAQUE_DATA_STATE, broken, 1.1)
    assert opaque.data == b"counts" and opaque.data_count == 1
    _feed(opaque, c.PLAYER_OPAQUE_DATA_STATE, table, 1.2)
    assert opaque.data == b"counts" and opaque.data_count == 2


def test_a_large_body_is_decoded_every_time_and_not_kept() -> None:
    opaque = OpaqueProxy(None)
    image = encode_payload(sm.OpaqueData(bytes(range(256)) * 64))
    _feed(opaque, c.PLAYER_OPAQUE_DATA_STATE, image, 1.0)
    _feed(opaque, c.PLAYER_OPAQUE_DATA_STATE, image, 1.1)
    assert opaque.data == bytes(range(256)) * 64 and opaque.data_count == 2
    assert opaque._decoded == {}
