"""The lockstep tick protocol over real loopback multicast and the Player team clock."""

from __future__ import annotations

import time

import pytest
from sibling import load_sibling

from murdoch.auction.messages import Bid
from murdoch.auth import TeamKey
from murdoch.endpoint import EndpointOptions
from murdoch.multicast import MulticastConfig, MulticastTransport
from murdoch.tick_order import LostDatagrams
from murdoch.transport import TickConfig
from player_server.drivers.base import Unsupported
from player_server.drivers.team_clock import TeamClock, TeamClockDriver
from player_server.protocol import constants as c
from player_server.protocol.sensor_msgs import OpaqueData
from player_server.protocol.team_clock import Declaration, decode_table

pytestmark = pytest.mark.timeout(60)
_multicast = load_sibling(__file__, "test_murdoch_multicast.py")


@pytest.fixture
def config() -> MulticastConfig:
    cfg = _multicast.free_config()
    if not _multicast.multicast_works(cfg):
        pytest.skip("UDP multicast on the loopback interface is not available on this machine")
    return cfg


def _pair(config: MulticastConfig, tick: list[int]) -> tuple[MulticastTransport, ...]:
    key = TeamKey("team-secret-1")
    out = []
    for name in ("p1", "p2"):
        ticks = TickConfig(lambda: tick[0], epoch="e1", ordered=True, late_joiner=False)
        out.append(MulticastTransport(name, lambda: tick[0] * 0.1, config,
                                      EndpointOptions(key=key, instance="0", ticks=ticks)))
    return tuple(out)


def test_declared_datagrams_are_waited_for_then_acted_on_in_tick_order(
    config: MulticastConfig,
) -> None:
    tick = [7]
    p1, p2 = _pair(config, tick)
    with p1, p2:
        sub = p2.subscribe({"task.x"})
        for i in range(5):
            p1.publish({"task.x"}, Bid("x", 1, "p1", float(i)))
        table = {"p1/0": p1.core.sent_count}
        tick[0] = 8
        delivered = p2.settle_tick(8, table, wait_clock=time.monotonic, give_up_after_s=10.0)
        assert delivered == 5
        got = sub.drain()
        assert [e.message.score for e in got] == [0.0, 1.0, 2.0, 3.0, 4.0]
        assert {e.tick for e in got} == {7}


def test_a_datagram_that_never_arrives_ends_the_tick_with_a_clear_error(
    config: MulticastConfig,
) -> None:
    tick = [3]
    p1, p2 = _pair(config, tick)
    with p1, p2:
        p1.publish({"task.x"}, Bid("x", 1, "p1", 1.0))
        # p1 claims two datagrams; the second was never sent (lost on the way)
        with pytest.raises(LostDatagrams, match=r"p1/0: 1"):
            p2.settle_tick(4, {"p1/0": 2}, wait_clock=time.monotonic, give_up_after_s=0.5)
        assert p2.counters.dropped["lost"] == 1


def test_the_team_clock_takes_each_robots_own_counts_and_refuses_the_rest() -> None:
    clock = TeamClock()
    p1 = TeamClockDriver(clock, "p1")
    cmd = c.PLAYER_OPAQUE_CMD_DATA
    p1.handle_command(cmd, OpaqueData(Declaration("p1/0", 4).encode()))
    clock.declare("user/0", 9)
    ((subtype, body),) = p1.data()
    assert subtype == c.PLAYER_OPAQUE_DATA_STATE
    assert decode_table(body.data) == {"p1/0": 4, "user/0": 9}
    hostile = [b'{"s":"p2/0","n":5}',  # another robot's count
               b'{"s":"p1/0","n":3}',  # going backwards
               b'{"s":"p1/0","n":1e308}', b'{"s":"p1/0","n":NaN}', b'{"s":"p1/0","n":-1}',
               b'{"s":"p1 0","n":5}', b"\xff\xfe", b"[1,2]", b'{"s":"p1/0","n":5,"x":1}',
               b"{" * 100_000]
    for data in hostile:
        with pytest.raises(Unsupported):
            p1.handle_command(cmd, OpaqueData(data))
    assert clock.rejected == len(hostile)
    assert clock.table() == {"p1/0": 4, "user/0": 9}
