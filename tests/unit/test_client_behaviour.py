"""The client against a scripted peer over loopback TCP (no server package involved)."""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from player_server.client import (
    LaserProxy,
    PlayerClient,
    PlayerConnectionClosed,
    PlayerConnectionError,
    PlayerNack,
    PlayerTimeout,
    Position2dProxy,
    RangerProxy,
)
from player_server.protocol import NEED_DATA, Decoder, Message, banner, encode_message
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.common import DevAddr, Pose2d

pytestmark = pytest.mark.timeout(30)

Script = Callable[["Peer"], None]


class Peer:
    """The server side of one connection, scripted by a test."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.dec = Decoder()
        self.received: list[Message] = []

    def expect(self) -> Message:
        while True:
            ev = self.dec.next_event()
            if isinstance(ev, Message):
                self.received.append(ev)
                return ev
            assert ev is NEED_DATA
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError
            self.dec.feed(chunk)

    def send(self, *wires: bytes) -> None:
        self.sock.sendall(b"".join(wires))

    def ack(self, m: Message, body: Any = None) -> bytes:
        return encode_message(m.interf, m.index, 4, m.subtype, body)

    def answer_handshake(self) -> None:
        m = self.expect()
        assert (m.interf, m.type, m.subtype, m.body.mode) == (1, 3, 5, 2)
        self.send(self.ack(m))


@contextmanager
def peer(script: Script, greeting: bytes = banner()) -> Iterator[tuple[int, list[BaseException]]]:
    ls = socket.socket()
    ls.bind(("127.0.0.1", 0))
    ls.listen(1)
    errors: list[BaseException] = []

    def run() -> None:
        conn, _ = ls.accept()
        conn.settimeout(10)
        try:
            conn.sendall(greeting)
            script(Peer(conn))
        except EOFError:
            pass
        except BaseException as exc:  # seen by the test
            errors.append(exc)
        finally:
            conn.close()

    t = threading.Thread(target=run, daemon=True)
    t.start()
    try:
        yield ls.getsockname()[1], errors
    finally:
        t.join(10)
        ls.close()
    assert not t.is_alive()


def pos_data(x: float, t: float) -> bytes:
    return encode_message(4, 0, 1, 1, am.Position2dData(Pose2d(x, 0, 0), Pose2d(), 0),
                          timestamp=t)


SYNCH = encode_message(1, 0, 5, 1)


def dev_ack(p: Peer, m: Message, name: str = "drv") -> bytes:
    return p.ack(m, pm.DeviceReq(DevAddr(0, 0, m.body.addr.interf, 0), m.body.access, name))


def test_handshake_subscribe_read_and_backlog() -> None:
    def script(p: Peer) -> None:
        p.answer_handshake()
        m = p.expect()
        p.send(dev_ack(p, m, "sim_position2d"))
        m = p.expect()  # REQ DATA
        assert (m.interf, m.subtype) == (1, 4)
        p.send(p.ack(m), pos_data(1.0, 0.1), SYNCH)
        m = p.expect()  # a request answered after stray data: data is kept for read()
        assert (m.interf, m.subtype) == (4, 1)
        p.send(p.ack(encode_msg_like(m, 2)), p.ack(encode_msg_like(m, 1, 5)), pos_data(2.0, 0.2),
               encode_message(4, 0, 4, 1, am.Position2dGeom()))
        m = p.expect()  # REQ DATA again
        p.send(p.ack(m), encode_message(1, 0, 5, 2, pm.SynchOverflow(2)))
        m = p.expect()  # unsubscribe
        p.send(dev_ack(p, m))

    with peer(script) as (port, errors), PlayerClient("127.0.0.1", port) as cl:
        assert cl.banner == "Player v.3.1.1-dev" and cl.mode == c.PLAYER_DATAMODE_PULL
        pos = cl.subscribe(Position2dProxy)
        assert pos.driver_name == "sim_position2d" and not pos.fresh
        assert cl.read() == [pos] and pos.x == 1.0 and cl.data_time_s == 0.1
        assert pos.get_geometry() == am.Position2dGeom()
        assert pos.x == 1.0  # the stray DATA waits for the next read
        assert cl.read() == [pos] and pos.x == 2.0 and pos.data_count == 2
        assert cl.overflow_count == 2
        cl.unsubscribe(pos)
    assert not errors


def encode_msg_like(m: Message, index: int, interf: int | None = None) -> Message:
    """A message whose reply does not match ``m`` (other index or interface)."""
    from player_server.protocol.header import Header

    h = m.header
    return Message(Header(0, 0, interf if interf is not None else h.interf, index, h.type,
                          h.subtype), None)


def test_nack_timeout_and_closed_connection() -> None:
    def script(p: Peer) -> None:
        p.answer_handshake()
        p.expect()
        p.send(encode_message(1, 0, 6, 3, pm.DeviceReq(DevAddr(0, 0, 6, 0), 3, "")))
        p.expect()  # a request never answered
        p.expect()

    with peer(script) as (port, errors):
        cl = PlayerClient("127.0.0.1", port, timeout_s=0.3).connect()
        with pytest.raises(PlayerNack) as info:
            cl.subscribe(LaserProxy)
        assert info.value.body.access == 3
        with pytest.raises(PlayerTimeout):
            cl.request(4, 0, 1)
        cl.close()
        with pytest.raises(PlayerConnectionError):
            cl.request(4, 0, 1)
    assert not errors


def test_server_closing_mid_read_is_a_connection_error() -> None:
    def script(p: Peer) -> None:
        p.answer_handshake()
        m = p.expect()
        p.send(p.ack(m), pos_data(1.0, 0.1))

    with peer(script) as (port, _), PlayerClient("127.0.0.1", port) as cl, \
            pytest.raises(PlayerConnectionError):
        cl.read(timeout_s=5)


def test_short_banner_fails_connect() -> None:
    def script(p: Peer) -> None:
        pass

    with peer(script, greeting=b"Player v.3") as (port, _), \
            pytest.raises(PlayerConnectionError):
        PlayerClient("127.0.0.1", port, timeout_s=1.0).connect()


def test_push_mode_and_stamped_ranger() -> None:
    def script(p: Peer) -> None:
        m = p.expect()  # PUSH is the connection default: no DATAMODE request
        assert (m.interf, m.subtype) == (1, 3)
        p.send(dev_ack(p, m), encode_message(62, 0, 1, 1, sm.RangerDataRange((1.0, 2.0))),
               encode_message(62, 0, 1, 2, sm.RangerDataRangestamped(
                   sm.RangerDataRange((3.0,)), 0, sm.RangerGeom(), 1,
                   sm.RangerConfig(-1.0, 1.0, 0.5, 0, 5, 0, 10))))

    with peer(script) as (port, errors), \
            PlayerClient("127.0.0.1", port, mode=c.PLAYER_DATAMODE_PUSH) as cl:
        ranger = cl.subscribe(RangerProxy)
        assert cl.read() == [ranger] and ranger.ranges == (1.0, 2.0)
        assert cl.read() == [ranger] and ranger.ranges == (3.0,)
        assert ranger.config is not None and ranger.bearings() == (-1.0,)
    assert not errors


def test_lockstep_opt_out_is_sent() -> None:
    def script(p: Peer) -> None:
        p.answer_handshake()
        m = p.expect()
        assert (m.subtype, m.body.key, m.body.value) == (253, "lockstep", 0)
        p.send(p.ack(m))

    with peer(script) as (port, errors):
        PlayerClient("127.0.0.1", port, lockstep=False).connect().close()
    assert not errors


def test_proxies_keep_typed_latest_values() -> None:
    cl = PlayerClient()
    laser = LaserProxy(cl, 0)
    laser._on_data(1, sm.LaserData(-1.0, 1.0, 0.5, 8.0, (1.0, 2.0, 3.0), b"", 4), 2.5)
    assert laser.ranges == (1.0, 2.0, 3.0) and laser.scan_id == 4
    assert laser.bearings() == (-1.0, -0.5, 0.0) and laser.data_time_s == 2.5
    assert laser.points()[2] == pytest.approx((3.0, 0.0))
    pos = Position2dProxy(cl, 0)
    assert (pos.x, pos.y, pos.yaw, pos.stall) == (0.0, 0.0, 0.0, False)
    pos._on_data(1, am.Position2dData(Pose2d(1, 2, 3), Pose2d(0.5, 0, 0.1), 1), 1.0)
    assert (pos.x, pos.y, pos.yaw, pos.vx, pos.vyaw, pos.stall) == (1, 2, 3, 0.5, 0.1, True)


def test_server_resetting_the_connection_is_a_close_not_a_failure() -> None:
    """A server that stops closes sockets with unread bytes in them, which the client sees as
    a reset (ECONNRESET): that is the server closing, reported as `PlayerConnectionClosed`."""
    unread = threading.Event()

    def script(p: Peer) -> None:
        p.answer_handshake()
        unread.wait(10)  # the client's next request stays unread in this socket
        p.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))

    with peer(script) as (port, errors), PlayerClient("127.0.0.1", port) as cl:
        cl.send_encoded(b"\0" * 64)  # bytes the peer never reads
        unread.set()
        with pytest.raises(PlayerConnectionClosed) as info:
            cl.request(4, 0, 1, timeout_s=10)
        assert "Errno" not in str(info.value)
        assert str(info.value) == "the server closed the connection"
    assert not errors


def test_orderly_close_is_also_a_close() -> None:
    def script(p: Peer) -> None:
        p.answer_handshake()

    with peer(script) as (port, _), PlayerClient("127.0.0.1", port) as cl, \
            pytest.raises(PlayerConnectionClosed):
        cl.request(4, 0, 1, timeout_s=10)
