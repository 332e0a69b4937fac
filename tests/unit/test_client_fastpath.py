"""The client's fast paths against a scripted peer over loopback TCP.

A PULL ``read`` sends REQ DATA and reads its ACK and the round in one pass (a lone ACK
does not wake the reader: SO_RCVLOWAT), and ``set_velocity`` packs its CMD in one go:
the same bytes as the generic encoder.
"""

from __future__ import annotations

import math
import time
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sibling import load_sibling

from player_server.client import PlayerClient, PlayerNack, Position2dProxy
from player_server.protocol import actuator_msgs as am
from player_server.protocol import encode_message
from player_server.protocol.common import Pose2d
from player_server.protocol.errors import EncodeError

pytestmark = pytest.mark.timeout(30)


# the scripted peer of the client's behaviour tests
_P = load_sibling(__file__, "test_client_behaviour.py")
peer, pos_data, dev_ack, SYNCH = _P.peer, _P.pos_data, _P.dev_ack, _P.SYNCH


def test_round_after_a_lone_ack_then_a_nack() -> None:
    def script(p: Any) -> None:
        p.answer_handshake()
        p.send(dev_ack(p, p.expect()))
        m = p.expect()  # REQ DATA: the ACK alone, the round later (lockstep)
        p.send(p.ack(m))
        time.sleep(0.05)
        p.send(pos_data(1.0, 0.1), SYNCH)
        m = p.expect()  # REQ DATA: the round first, then the ACK
        p.send(pos_data(2.0, 0.2), SYNCH)
        time.sleep(0.02)
        p.send(p.ack(m))
        m = p.expect()  # a request after that gets its own reply
        p.send(p.ack(m, am.Position2dGeom()))
        m = p.expect()  # REQ DATA refused: a lone NACK must still get through
        p.send(encode_message(1, 0, 6, 4))
        p.expect()

    with peer(script) as (port, errors), PlayerClient("127.0.0.1", port) as cl:
        pos = cl.subscribe(Position2dProxy)
        assert cl.read() == [pos] and pos.x == 1.0 and cl.data_time_s == 0.1
        assert cl.read() == [pos] and pos.x == 2.0 and cl.rounds == 2
        assert pos.get_geometry() == am.Position2dGeom()
        t0 = time.monotonic()
        with pytest.raises(PlayerNack):
            cl.read(timeout_s=5.0)
        assert time.monotonic() - t0 < 2.0  # one receive slice, not the timeout
        assert pos.x == 2.0
        # the connection is still usable: the next read asks again
        cl.close()
    assert not errors


def _client(clock_s: float) -> tuple[PlayerClient, list[bytes]]:
    cl = PlayerClient("127.0.0.1", 1, clock=lambda: clock_s)
    sent: list[bytes] = []
    cl._send = sent.append  # type: ignore[method-assign]  # capture instead of a socket
    return cl, sent


finite = st.floats(allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(finite | st.sampled_from([math.inf, -math.inf, -0.0]), finite, finite, st.booleans(),
       st.integers(0, 3), st.floats(0, 1e9))
def test_set_velocity_sends_the_generic_bytes(
    vx: float, vyaw: float, vy: float, enable: bool, index: int, now: float
) -> None:
    cl, sent = _client(now)
    Position2dProxy(cl, index).set_velocity(vx, vyaw, vy, enable)
    Position2dProxy(cl, index).command(1, am.Position2dCmdVel(Pose2d(vx, vy, vyaw), int(enable)))
    assert sent[0] == sent[1] == encode_message(
        4, index, 2, 1, am.Position2dCmdVel(Pose2d(vx, vy, vyaw), int(enable)), timestamp=now)


def test_set_velocity_nan_and_bad_values() -> None:
    cl, sent = _client(1.0)
    Position2dProxy(cl).set_velocity(math.nan, 0.0)
    assert sent[0][:40] == encode_message(4, 0, 2, 1, am.Position2dCmdVel(), timestamp=1.0)[:40]
    assert math.isnan(am.Position2dCmdVel.xdr_decode(sent[0], 40)[0].vel.px)
    with pytest.raises(EncodeError):
        Position2dProxy(cl).set_velocity("fast", 0.0)  # type: ignore[arg-type]
    assert len(sent) == 1


def test_a_deferred_command_leaves_with_the_next_request_for_data() -> None:
    seen: list[tuple[int, int, int]] = []

    def script(p: Any) -> None:
        p.answer_handshake()
        p.send(dev_ack(p, p.expect()))
        for x in (1.0, 2.0):
            cmd = p.expect()
            seen.append((cmd.type, cmd.subtype, round(cmd.body.vel.px * 10)))
            m = p.expect()  # the REQ DATA, after the command
            seen.append((m.type, m.subtype, 0))
            p.send(p.ack(m), pos_data(x, x / 10), SYNCH)
        cmd = p.expect()  # held back until close
        seen.append((cmd.type, cmd.subtype, round(cmd.body.vel.px * 10)))

    with peer(script) as (port, errors), PlayerClient("127.0.0.1", port) as cl:
        pos = cl.subscribe(Position2dProxy)
        pos.set_velocity(0.3, 0.0, defer=True)
        assert cl.read() == [pos] and pos.x == 1.0
        pos.set_velocity(0.4, 0.0, defer=True)
        assert cl.read() == [pos] and pos.x == 2.0
        pos.set_velocity(0.5, 0.0, defer=True)
        cl.close()
    assert not errors
    assert seen == [(2, 1, 3), (3, 4, 0), (2, 1, 4), (3, 4, 0), (2, 1, 5)]  # CMD VEL, REQ DATA
