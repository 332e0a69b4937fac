"""DATA bodies taken where they lie in the receive buffer.

The proxies of the per-tick devices read their common bodies with one ``struct`` call
each; whatever they take must equal what the generic decoder makes of the same bytes, a
body that does not check out must be refused without touching the proxy, and the client
must frame rounds that arrive split, large or with a bad body in the middle.
"""

from __future__ import annotations

import socket
import time
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sibling import load_sibling

from player_server.client import (
    BlobfinderProxy,
    BumperProxy,
    CameraProxy,
    LaserProxy,
    PlayerClient,
    Position2dProxy,
    PowerProxy,
    Proxy,
    SonarProxy,
)
from player_server.client.framing import FrameBuffer
from player_server.protocol import actuator_msgs as am
from player_server.protocol import encode_message
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.codec import decode_body
from player_server.protocol.common import Pose2d
from player_server.protocol.errors import DecodeError

pytestmark = pytest.mark.timeout(60)


# the scripted peer of the client's behaviour tests
_P = load_sibling(__file__, "test_client_behaviour.py")
peer, pos_data, dev_ack, SYNCH = _P.peer, _P.pos_data, _P.dev_ack, _P.SYNCH

f32 = st.floats(width=32, allow_nan=False)
f64 = st.floats(allow_nan=False)
u32 = st.integers(0, 2**32 - 1)
ranges = st.lists(f32, max_size=40).map(tuple)
blob = st.builds(sm.BlobfinderBlob, u32, u32, u32, u32, u32, u32, u32, u32, u32, f32)

BODIES = {
    Position2dProxy: st.builds(am.Position2dData, st.builds(Pose2d, f64, f64, f64),
                               st.builds(Pose2d, f64, f64, f64), st.integers(0, 1)),
    SonarProxy: st.builds(sm.SonarData, ranges),
    LaserProxy: st.builds(sm.LaserData, f32, f32, f32, f32, ranges,
                          st.binary(max_size=9), u32),
    BlobfinderProxy: st.builds(sm.BlobfinderData, u32, u32,
                               st.lists(blob, max_size=5).map(tuple)),
    PowerProxy: st.builds(am.PowerData, u32, f32, f32, f32, f32,
                          st.integers(-(2**31), 2**31 - 1)),
    BumperProxy: st.builds(sm.BumperData, st.binary(max_size=7)),
}


def _view(proxy: Proxy) -> tuple[Any, ...]:
    """Everything a reader of the proxy can see of its latest DATA."""
    if isinstance(proxy, Position2dProxy):
        return (proxy.state, proxy.state_values, proxy.x, proxy.vyaw, proxy.stall)
    if isinstance(proxy, SonarProxy):
        return (proxy.ranges,)
    if isinstance(proxy, LaserProxy):
        return (proxy.scan, proxy.scan_values, proxy.ranges, proxy.intensity, proxy.scan_id,
                repr(proxy.bearings()))  # repr: a NaN bearing equals itself
    if isinstance(proxy, BlobfinderProxy):
        return (proxy.state, proxy.blob_values, proxy.blobs, proxy.width, proxy.height)
    if isinstance(proxy, PowerProxy):
        return (proxy.state, proxy.state_values, proxy.percent, proxy.charging)
    assert isinstance(proxy, BumperProxy)
    return (proxy.bumpers, proxy.pressed)


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_taken_in_place_equals_the_generic_decoder(data: st.DataObject) -> None:
    cls = data.draw(st.sampled_from(sorted(BODIES, key=lambda c: c.__name__)))
    body = data.draw(BODIES[cls])
    wire = type(body).xdr_encode(body)
    offset = data.draw(st.integers(0, 9))
    buf = bytearray(offset) + wire + b"\xff" * 8  # the bytes of the next frame follow
    fast, slow = cls(PlayerClient()), cls(PlayerClient())
    fast._on_raw(1, buf, offset, offset + len(wire), 2.5)
    slow._on_data(1, decode_body(type(body), wire), 2.5)
    assert _view(fast) == _view(slow)
    assert (fast.data_count, fast.data_time_s) == (1, 2.5)


@pytest.mark.parametrize(("cls", "body", "cut"), [
    (Position2dProxy, am.Position2dData(), 4),
    (SonarProxy, sm.SonarData((1.0, 2.0)), 4),
    (LaserProxy, sm.LaserData(ranges=(1.0, 2.0), intensity=b"ab"), 4),
    (BlobfinderProxy, sm.BlobfinderData(1, 2, (sm.BlobfinderBlob(),)), 4),
    (PowerProxy, am.PowerData(), 4),
    (BumperProxy, sm.BumperData(b"\x01\x00"), 4),
])
def test_a_body_that_does_not_check_out_is_refused(cls: type[Proxy], body: Any,
                                                   cut: int) -> None:
    wire = type(body).xdr_encode(body)
    proxy = cls(PlayerClient())
    for bad in (wire[:-cut], wire + b"\0" * cut):
        with pytest.raises(DecodeError):
            proxy._on_raw(1, bad, 0, len(bad), 1.0)
    assert proxy.data_count == 0 and proxy.data_time_s is None
    counts = bytearray(wire)
    if cls not in (Position2dProxy, PowerProxy):  # a count field to break
        at = 16 if cls is LaserProxy else 8 if cls is BlobfinderProxy else 0
        counts[at + 7] ^= 1  # the two counts disagree
        with pytest.raises(DecodeError):
            proxy._on_raw(1, counts, 0, len(counts), 1.0)
    assert proxy.data_count == 0
    proxy._on_raw(1, wire, 0, len(wire), 3.0)
    assert proxy.data_count == 1 and proxy.data_time_s == 3.0


def test_other_subtypes_take_the_generic_path() -> None:
    laser = LaserProxy(PlayerClient())
    scanpose = sm.LaserDataScanpose(sm.LaserData(ranges=(4.0,), id=7), Pose2d(1, 2, 3))
    wire = scanpose.xdr_encode(scanpose)
    laser._on_raw(2, wire, 0, len(wire), 1.0)  # DATA_SCANPOSE
    assert laser.ranges == (4.0,) and laser.scan_id == 7 and laser.scan == scanpose.scan


def sonar_data(r: tuple[float, ...], t: float) -> bytes:
    return encode_message(5, 0, 1, 1, sm.SonarData(r), timestamp=t)


def test_a_bad_body_mid_round_is_skipped_and_split_rounds_are_framed() -> None:
    image = sm.CameraData(700, 200, 24, 0, 1, 0, bytes(range(256)) * 1641)  # > 256 KiB

    def script(p: Any) -> None:
        p.answer_handshake()
        for _ in range(3):
            p.send(dev_ack(p, p.expect()))
        m = p.expect()  # REQ DATA: a sonar body whose counts disagree, then good data
        bad = bytearray(sonar_data((1.0, 2.0), 0.1))
        bad[47] ^= 1
        p.send(p.ack(m), bytes(bad), pos_data(1.0, 0.1), sonar_data((3.0,), 0.1), SYNCH)
        m = p.expect()  # REQ DATA: the round dribbles in, a few bytes at a time
        wire = p.ack(m) + pos_data(2.0, 0.2) + sonar_data((5.0, 6.0), 0.2) + SYNCH
        for i in range(0, len(wire), 7):
            p.send(wire[i:i + 7])
            time.sleep(0.001)
        m = p.expect()  # REQ DATA: an image larger than the receive buffer
        p.send(p.ack(m), encode_message(40, 0, 1, 1, image, timestamp=0.3), SYNCH)

    with peer(script) as (port, errors), PlayerClient("127.0.0.1", port) as cl:
        pos, sonar = cl.subscribe(Position2dProxy), cl.subscribe(SonarProxy)
        camera = cl.subscribe(CameraProxy)
        assert cl.read() == [pos, sonar]
        assert (pos.x, sonar.ranges, sonar.data_count, cl.undecodable) == (1.0, (3.0,), 1, 1)
        assert cl.read() == [pos, sonar] and sonar.ranges == (5.0, 6.0) and pos.x == 2.0
        assert cl.read() == [camera] and camera.state == image and cl.data_time_s == 0.3
        assert cl.rounds == 3
    assert not errors


def test_laser_ranges_are_decoded_when_first_read_and_a_kept_body_stays_put() -> None:
    laser = LaserProxy(PlayerClient())
    first = sm.LaserData(-1.0, 1.0, 1.0, 8.0, (1.0, 2.0, 3.0), b"\x07", 9)
    wire = bytearray(first.xdr_encode(first))
    laser._on_raw(1, wire, 0, len(wire), 1.0)
    body = laser.scan_body
    assert body is not None and body.count == 3 and body._values is None  # not decoded yet
    wire[24:36] = bytes(12)  # the receive buffer is reused for the next round
    assert body.values() == (-1.0, 1.0, 1.0, 8.0, (1.0, 2.0, 3.0), b"\x07", 9)
    assert laser.scan == first and laser.scan_body is body


def test_a_full_frame_buffer_grows_instead_of_receiving_nothing() -> None:
    frames = FrameBuffer(64)
    frames.end = 64  # one unfinished frame fills it
    a, b = socket.socketpair()
    with a, b:
        b.sendall(b"x" * 10)
        assert frames.receive(a) == 10 and frames.end == 74 and len(frames.buf) > 74
        frames.start = frames.end  # all taken: the next receive starts at the front again
        b.sendall(b"y" * 3)
        assert frames.receive(a) == 3 and (frames.start, frames.end) == (0, 3)
        assert bytes(frames.buf[:3]) == b"yyy"
