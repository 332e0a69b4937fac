"""Server data path: DATA encoded once per tick and device, a round in one write."""

from __future__ import annotations

from sibling import load_sibling

from player_server.protocol import Decoder, Message, encode_message
from player_server.protocol import actuator_msgs as am
from player_server.protocol.common import Pose2d
from player_server.server.core import ServerCore
from player_server.server.endpoint import Endpoint

_T = load_sibling(__file__, "test_server_core.py")
CountingPosition = _T.CountingPosition


def test_data_is_encoded_once_per_tick_and_a_round_is_one_write() -> None:
    world = {"t": 0.0}
    drv = CountingPosition(world)
    ep = Endpoint("r1", {(4, 0): drv, (5, 0): _T.FakeSonar()}, port=7001)
    core = ServerCore([ep], lambda: world["t"])
    a, b = _T.connect(core, ep), _T.connect(core, ep)
    for s in (a, b):
        core.receive(s, _T.sub(4) + _T.sub(5))
        core.take_output(s)
    for tick in range(1, 4):
        world["t"] = tick / 10
        core.publish()
        core.receive(a, _T.DATA)
        core.receive(b, _T.DATA)
        assert a.queue.replies_waiting == b.queue.replies_waiting == 2  # ACK + whole round
        wa, wb = core.take_output(a), core.take_output(b)
        assert wa == wb  # the same bytes for both clients, from one call of the driver
        dec = Decoder()
        dec.feed(wa)
        msgs = dec.events()
        assert [(m.type, m.interf) for m in msgs] == [(4, 1), (1, 4), (1, 5), (5, 1)]
        assert all(isinstance(m, Message) for m in msgs)
        assert wa[40:-40] == encode_message(
            4, 0, 1, 1, am.Position2dData(Pose2d(tick / 10, 0, 0), Pose2d(), 0),
            timestamp=tick / 10, robot=7001) + encode_message(
            5, 0, 1, 1, _T.FakeSonar().data()[0][1], timestamp=tick / 10, robot=7001)
    assert drv.reads == 3  # once per tick, not once per client
