"""One group by default, the optional reply lane, and the header filter, on real loopback
multicast."""

from __future__ import annotations

import dataclasses
import json
import select
import socket
import time

import pytest
from sibling import load_sibling

from murdoch.auction.messages import Award, Bid, Renew, Report
from murdoch.multicast import MulticastConfig, MulticastTransport, open_multicast_socket
from murdoch.wire import Envelope

_multicast = load_sibling(__file__, "test_murdoch_multicast.py")


def free_config(reply_lane: bool) -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port,
                           reply_lane=reply_lane)


def checked_config(reply_lane: bool) -> MulticastConfig:
    cfg = free_config(reply_lane)
    if _multicast.multicast_works(cfg):
        return cfg
    pytest.skip("UDP multicast on the loopback interface is not available on this machine")


@pytest.fixture
def config() -> MulticastConfig:
    """A configuration with the reply lane on."""
    return checked_config(reply_lane=True)


@pytest.fixture
def one_group() -> MulticastConfig:
    """The default: one group and port."""
    return checked_config(reply_lane=False)


def poll_for(transport: MulticastTransport, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        transport.poll(0.01)


def test_reply_lane_is_an_option_on_another_group_on_the_same_port() -> None:
    assert not MulticastConfig().reply_lane  # one group by default
    config = MulticastConfig(group="239.255.74.17", port=47017, reply_lane=True)
    assert config.replies_group == "239.255.74.18"
    assert MulticastConfig(group="239.255.255.255").replies_group == "239.255.255.254"
    assert MulticastConfig(reply_group="239.255.9.9").replies_group == "239.255.9.9"
    lane = config.reply_config()
    assert (lane.group, lane.port, lane.replies_group) == ("239.255.74.18", 47017, config.group)
    with pytest.raises(ValueError, match="differ"):
        MulticastConfig(group="239.255.1.1", reply_group="239.255.1.1")
    with pytest.raises(ValueError, match="multicast"):
        MulticastConfig(reply_group="10.1.2.3")


@pytest.mark.timeout(30)
def test_by_default_everything_travels_on_one_group_as_one_json_value(
    one_group: MulticastConfig,
) -> None:
    main_tap = open_multicast_socket(one_group)
    reply_tap = open_multicast_socket(dataclasses.replace(one_group, reply_lane=True)
                                      .reply_config())
    try:
        with MulticastTransport("tx", time.monotonic, one_group) as tx, \
                MulticastTransport("rx", time.monotonic, one_group) as rx:
            got: list[Envelope] = []
            sub = rx.subscribe({"task.t"}, callback=got.append)
            sub.wake_on_replies = False  # nothing to wait on apart: every datagram wakes
            sent = [Bid("t", 1, "tx", 1.0), Renew("t", 1, "tx", 1), Award("t", 1, "tx", 1.0, 1, ""),
                    Report("t", 1, "tx", "completed", "")]
            for message in sent:
                tx.publish({"task.t"}, message)
            seen = []
            while len(seen) < len(sent) and select.select([main_tap], [], [], 2.0)[0]:
                seen.append(json.loads(main_tap.recv(2048)))  # one JSON value, whole
            assert [obj["h"][:3] for obj in seen] == [[3, m.KIND, "tx"] for m in sent]
            assert [obj["h"][4] for obj in seen] == [0, 1, 2, 3]
            assert all(set(obj) == {"h", "b"} for obj in seen)
            with pytest.raises(BlockingIOError):
                reply_tap.recv(2048)  # nothing went to a second group
            started = time.monotonic()
            while len(got) < len(sent) and time.monotonic() - started < 2.0:
                rx.poll(1.0)
            assert [e.kind for e in got] == [m.KIND for m in sent]
            assert time.monotonic() - started < 0.9  # woken by the replies, no timeout
    finally:
        main_tap.close()
        reply_tap.close()


@pytest.mark.timeout(30)
def test_replies_travel_apart_and_every_one_is_still_delivered(config: MulticastConfig) -> None:
    main_tap = open_multicast_socket(config)
    reply_tap = open_multicast_socket(config.reply_config())
    try:
        with MulticastTransport("tx", time.monotonic, config) as tx:
            tx.publish({"task.t"}, Bid("t", 1, "tx", 1.0))
            tx.publish({"task.t"}, Renew("t", 1, "tx", 1))
            ready = select.select([main_tap], [], [], 2.0)[0]
            assert ready and main_tap.recv(2048).startswith(b'{"h":[3,"renew","tx",')
            ready = select.select([reply_tap], [], [], 2.0)[0]
            assert ready and reply_tap.recv(2048).startswith(b'{"h":[3,"bid","tx",')
            with pytest.raises(BlockingIOError):
                main_tap.recv(2048)  # the bid did not go to the main group
    finally:
        main_tap.close()
        reply_tap.close()


@pytest.mark.timeout(30)
def test_a_lazy_subscriber_is_not_woken_by_replies_but_reads_them_before_what_follows(
    config: MulticastConfig,
) -> None:
    with MulticastTransport("bidder", time.monotonic, config) as bidder, \
            MulticastTransport("auctioneer", time.monotonic, config) as auctioneer:
        got: list[Envelope] = []
        sub = bidder.subscribe({"task.t"}, callback=got.append)
        sub.wake_on_replies = False
        assert not bidder.core.wants_replies
        for n in range(5):
            auctioneer.publish({"task.t"}, Bid("t", 1, f"b{n}", float(n)))
        time.sleep(0.05)  # they are queued on the bidder's reply socket
        started = time.monotonic()
        bidder.poll(0.3)  # nothing on the main lane: waits the whole timeout ...
        assert time.monotonic() - started >= 0.25
        assert [e.message.bidder for e in got] == [f"b{n}" for n in range(5)]  # ... then reads
        got.clear()
        for n in range(3):
            auctioneer.publish({"task.t"}, Bid("t", 1, f"late{n}", 0.5))
        auctioneer.publish({"task.t"}, Award("t", 1, "b4", 4.0, 8, ""))
        auctioneer.publish({"task.t"}, Renew("t", 1, "b4", 1))
        deadline = time.monotonic() + 2.0
        while not any(e.kind == "renew" for e in got) and time.monotonic() < deadline:
            bidder.poll(0.5)  # woken by the renewal, read after the replies sent before it
        assert [e.kind for e in got] == ["bid", "bid", "bid", "award", "renew"]
        # a subscription that wants replies is woken by them
        got.clear()
        sub.wake_on_replies = True
        assert bidder.core.wants_replies
        auctioneer.publish({"task.t"}, Report("t", 1, "b4", "completed", ""))
        started = time.monotonic()
        while not got and time.monotonic() - started < 2.0:
            bidder.poll(1.5)
        assert [e.kind for e in got] == ["report"]


JUNK = (b'{"h":[3,"bid","tx","","x","task.mine",-1,""],"b":{}}', b'{"h":[3,"bid","tx"],"b":{}}',
        b'{"h":[1,"bid","tx","",1,"a"],"b":{}}', b'{"h":[3,"bid","t\xffx","",1,"task.mine",-1,""]}',
        b'{"h":[3,"bid","tx","",3,"task.mine",-1,""],"b":[]}')
"""Five broken datagrams: four malformed, one of another version."""


@pytest.mark.parametrize("reply_lane", [False, True], ids=["one-group", "reply-lane"])
@pytest.mark.timeout(30)
def test_traffic_nobody_listens_to_is_counted_not_decoded_and_the_rest_gets_through(
    reply_lane: bool,
) -> None:
    config = checked_config(reply_lane)
    lanes = 2 if reply_lane else 1
    with MulticastTransport("rx", time.monotonic, config) as rx, \
            MulticastTransport("tx", time.monotonic, config) as tx:
        got: list[Envelope] = []
        rx.subscribe({"task.mine", "camera"}, callback=got.append)
        for n in range(4):
            tx.publish({"task.other"}, Bid("other", 1, "tx", float(n)))
        tx.send_raw(b'{"h":[3,"bid","tx","",9,"task.other",-1,""],"b":{this is not json}',
                    reply=True)
        for junk in JUNK:
            tx.send_raw(junk)
            if reply_lane:
                tx.send_raw(junk, reply=True)
        tx.publish({"task.mine"}, Bid("mine", 1, "tx", 7.0))
        tx.publish({"task.mine"}, Renew("mine", 1, "tx", 1))
        deadline = time.monotonic() + 2.0
        while len(got) < 2 and time.monotonic() < deadline:
            rx.poll(0.05)
        poll_for(rx, 0.1)
        assert [(e.kind, e.message.task_id) for e in got] == [("bid", "mine"), ("renew", "mine")]
        dropped = rx.counters.dropped
        assert dropped.get("unmatched") == 5  # four bids and the broken body: never parsed
        assert dropped.get("malformed") == 4 * lanes and dropped.get("bad_version") == lanes
        assert rx.counters.received("bid") == 4 + 1 + 1


@pytest.mark.timeout(30)
@pytest.mark.parametrize("lanes", ["one_group", "config"])
def test_a_resting_subscriber_is_woken_by_nothing_and_then_reads_everything(
    lanes: str, request: pytest.FixtureRequest
) -> None:
    cfg: MulticastConfig = request.getfixturevalue(lanes)
    with MulticastTransport("bidder", time.monotonic, cfg) as bidder, \
            MulticastTransport("auctioneer", time.monotonic, cfg) as auctioneer:
        got: list[Envelope] = []
        sub = bidder.subscribe({"task.t", "camera"}, callback=got.append)
        sub.wake_on_traffic = False
        assert not bidder.core.wants_traffic and not bidder.core.wants_replies
        auctioneer.publish({"task.t"}, Bid("t", 1, "b1", 1.0))
        auctioneer.publish({"camera"}, Renew("t", 1, "b1", 1))
        time.sleep(0.05)  # both are queued
        started = time.monotonic()
        bidder.poll(0.3)  # traffic is waiting, yet only the timeout ends the wait ...
        assert time.monotonic() - started >= 0.25
        assert sorted(e.kind for e in got) == ["bid", "renew"]  # ... then all of it is read
        got.clear()
        sub.wake_on_traffic = True
        assert bidder.core.wants_traffic
        auctioneer.publish({"camera"}, Renew("t", 1, "b1", 2))
        started = time.monotonic()
        while not got and time.monotonic() - started < 2.0:
            bidder.poll(1.5)
        assert [e.kind for e in got] == ["renew"]
        assert time.monotonic() - started < 1.0  # woken by it, not by the timeout
