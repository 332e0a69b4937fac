"""UDP multicast on loopback: one host, several sockets, real datagrams."""

from __future__ import annotations

import socket
import time

import pytest

from murdoch.auction.messages import Bid
from murdoch.multicast import MulticastConfig, MulticastTransport, open_multicast_socket
from murdoch.wire import Envelope


def free_config() -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port)


def multicast_works(config: MulticastConfig) -> bool:
    try:
        with MulticastTransport("probe", time.monotonic, config) as probe:
            sub = probe.subscribe({"probe"})
            probe.publish({"probe"}, Bid("p", 1, "probe", 0.0))
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline and not sub.drain():
                if probe.poll(0.05):
                    return True
    except OSError:
        return False
    return False


@pytest.fixture
def config() -> MulticastConfig:
    cfg = free_config()
    if not multicast_works(cfg):
        pytest.skip("UDP multicast on the loopback interface is not available on this machine")
    return cfg


def poll_until(transports: list[MulticastTransport], done, timeout_s: float = 2.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        for transport in transports:
            transport.poll(0.01)


@pytest.mark.timeout(30)
def test_every_socket_on_the_host_gets_every_datagram(config: MulticastConfig) -> None:
    got: dict[str, list[Envelope]] = {"a": [], "b": [], "c": []}
    transports = [MulticastTransport(n, time.monotonic, config) for n in got]
    try:
        for transport in transports:
            transport.subscribe({"task.t"}, callback=got[transport.sender_id].append)
        for n in range(20):
            transports[n % 3].publish({"task.t"}, Bid("t", 1, f"x{n}", float(n)))
        poll_until(transports, lambda: all(len(v) == 20 for v in got.values()))
        for name, envelopes in got.items():
            assert sorted(e.message.score for e in envelopes) == [float(n) for n in range(20)], name
        assert transports[0].counters.sent("bid") == 7
        assert transports[1].counters.received("bid") == 20
    finally:
        for transport in transports:
            transport.close()


@pytest.mark.timeout(30)
def test_sockets_are_loopback_only_with_ttl_zero(config: MulticastConfig) -> None:
    sock = open_multicast_socket(config)
    try:
        iface = sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, 4)
        assert socket.inet_ntoa(iface) == "127.0.0.1"
        assert sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL) == 0
        assert sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP) == 1
        assert sock.getsockname() == (config.group, config.port)
    finally:
        sock.close()
    with pytest.raises(ValueError, match="ttl"):
        MulticastConfig(ttl=5)
    with pytest.raises(ValueError, match="multicast"):
        MulticastConfig(group="10.0.0.1")


@pytest.mark.timeout(30)
def test_garbage_on_the_group_is_counted_and_harmless(config: MulticastConfig) -> None:
    with MulticastTransport("rx", time.monotonic, config) as rx, MulticastTransport(
        "tx", time.monotonic, config
    ) as tx:
        sub = rx.subscribe({"task.t"})
        for junk in (b"", b"\x00\x01", b'{"v":1}', b'{"v":9,"k":"bid"}', b"{" * 3000):
            tx.send_raw(junk)
        tx.publish({"task.t"}, Bid("t", 1, "tx", 1.0))
        received: list[Envelope] = []
        poll_until([rx], lambda: bool(received.extend(sub.drain()) or received))
        assert [e.message.bidder for e in received] == ["tx"]
        assert sum(rx.counters.dropped.values()) == 5


@pytest.mark.timeout(30)
def test_a_seeded_loss_layer_drops_and_delays_what_one_receiver_reads(
        config: MulticastConfig) -> None:
    from murdoch.endpoint import EndpointOptions
    from murdoch.lossy import LossSpec, LossyReceiver
    from murdoch.transport import TickConfig

    got: list[Envelope] = []
    loss = LossyReceiver(LossSpec(0.3, 0.05, 7), "lossy", time.monotonic)
    sender = MulticastTransport("s", time.monotonic, config)
    lossy = MulticastTransport("lossy", time.monotonic, config, loss=loss)
    try:
        lossy.subscribe({"task.t"}, callback=got.append)
        for n in range(200):
            sender.publish({"task.t"}, Bid("t", 1, f"x{n}", float(n)))
        poll_until([lossy], lambda: loss.dropped + len(got) >= 200 and not loss.pending(),
                   timeout_s=5.0)
        assert loss.dropped + len(got) == 200
        assert 30 <= loss.dropped <= 90 and loss.delayed > 0
        scores = [e.message.score for e in got]
        assert len(set(scores)) == len(scores)  # nothing twice
        # the same seed and arrivals drop the same datagrams
        again = LossyReceiver(LossSpec(0.3, 0.05, 7), "lossy", time.monotonic)
        for n in range(200):
            again.offer(str(n).encode())
        assert again.dropped == loss.dropped
    finally:
        sender.close()
        lossy.close()
    with pytest.raises(ValueError, match="lockstep"):
        MulticastTransport("x", time.monotonic, config,
                           EndpointOptions(ticks=TickConfig(lambda: 0, ordered=True)), loss=loss)
