"""MURDOCH over real Zenoh sessions on loopback: a hub (router) and clients over TCP."""

from __future__ import annotations

import os
import re
import socket
import time
from collections.abc import Callable, Iterator

import pytest

from murdoch.auction.messages import Bid
from murdoch.auth import TeamKey
from murdoch.endpoint import EndpointOptions
from murdoch.tick_order import LostDatagrams
from murdoch.transport import TickConfig
from murdoch.wire import Envelope
from murdoch.zenoh_transport import ZenohConfig, ZenohTransport, parse_endpoint

pytest.importorskip("zenoh", reason="the zenoh extra (eclipse-zenoh) is not installed")
pytestmark = pytest.mark.timeout(120)


def free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def team(names: list[str], options: EndpointOptions | None = None) -> list[ZenohTransport]:
    """The first name is the hub; the others connect to it."""
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    prefix = f"test/t{os.getpid()}"
    out: list[ZenohTransport] = []
    try:
        for i, name in enumerate(names):
            config = ZenohConfig(endpoint=endpoint, hub=i == 0, prefix=prefix)
            out.append(ZenohTransport(name, time.monotonic, config, options))
    except BaseException:
        for t in out:
            t.close()
        raise
    return out


def poll_until(transports: list[ZenohTransport], done: Callable[[], bool],
               timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        for t in transports:
            t.poll(0.01)


def connected(transports: list[ZenohTransport]) -> None:
    """Wait until each transport hears each other one (subscriptions reach the hub)."""
    heard: dict[str, set[str]] = {t.sender_id: set() for t in transports}
    subs = [t.subscribe({"probe"}, callback=lambda e, n=t.sender_id: heard[n].add(e.sender))
            for t in transports]
    names = set(heard)
    deadline = time.monotonic() + 30.0
    while any(h != names for h in heard.values()) and time.monotonic() < deadline:
        for t in transports:
            t.publish({"probe"}, Bid("probe", 1, t.sender_id, 0.0))
        poll_until(transports, lambda: all(h == names for h in heard.values()), 0.3)
    for s in subs:
        s.close()
    assert all(h == names for h in heard.values()), heard


@pytest.fixture
def trio() -> Iterator[list[ZenohTransport]]:
    transports = team(["hub", "a", "b"])
    try:
        connected(transports)
        yield transports
    finally:
        for t in transports:
            t.close()


def test_a_message_reaches_every_subscriber_holding_all_its_subjects(
    trio: list[ZenohTransport],
) -> None:
    hub, a, b = trio
    got: dict[str, list[Envelope]] = {"hub": [], "a": [], "b": []}
    hub.subscribe({"camera", "mobile", "idle"}, callback=got["hub"].append)
    a.subscribe({"camera", "idle"}, callback=got["a"].append)
    b.subscribe({"laser", "mobile"}, callback=got["b"].append)
    cases = [({"camera", "idle"}, {"hub", "a"}), ({"mobile"}, {"hub", "b"}),
             ({"camera", "laser"}, set()), ({"camera", "mobile", "idle"}, {"hub"})]
    for n, (subjects, _) in enumerate(cases):
        trio[n % 3].publish(subjects, Bid("t", 1, f"s{n}", float(n)))
    expected = {name: sorted(float(n) for n, (_, who) in enumerate(cases) if name in who)
                for name in got}
    poll_until(trio, lambda: all(len(got[k]) == len(v) for k, v in expected.items()))
    # a little longer: nothing unexpected may follow
    poll_until(trio, lambda: False, 0.3)
    assert {k: sorted(e.message.score for e in v) for k, v in got.items()} == expected
    assert a.counters.sent("bid") >= 1 and b.counters.received("bid") >= 4


def test_forged_and_malformed_datagrams_are_refused_and_counted() -> None:
    key = TeamKey("team-secret-1")
    transports = team(["hub", "a"], EndpointOptions(key=key))
    hub, a = transports
    try:
        connected(transports)
        got: list[Envelope] = []
        hub.subscribe({"task.x"}, callback=got.append)
        forger = TeamKey("other-secret-2")
        signed = a.core.encode({"task.x"}, Bid("x", 1, "a", 1.0))
        unsigned_twin = signed[: signed.rindex(b',"mac":')] + b"}"
        a.send_raw(forger.sign(unsigned_twin))            # wrong key
        a.send_raw(b"\x00not json at all")                # garbage
        a.send_raw(signed)                                # the real one
        a.send_raw(signed)                                # replayed
        poll_until(transports, lambda: sum(hub.counters.dropped.values()) >= 3 and bool(got))
        assert [e.message.score for e in got] == [1.0]
        dropped = hub.counters.dropped
        assert dropped.get("auth_failed", 0) >= 1
        assert dropped.get("replayed", 0) == 1
        assert sum(dropped.values()) >= 3
    finally:
        for t in transports:
            t.close()


def test_lockstep_release_waits_for_declared_datagrams_and_keeps_tick_order() -> None:
    tick = [7]
    key = TeamKey("team-secret-1")

    def ticks() -> TickConfig:
        return TickConfig(lambda: tick[0], epoch="e1", ordered=True, late_joiner=False)

    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    p1 = ZenohTransport("p1", lambda: tick[0] * 0.1, ZenohConfig(endpoint, hub=True),
                        EndpointOptions(key=key, instance="0", ticks=ticks()))
    p2 = ZenohTransport("p2", lambda: tick[0] * 0.1, ZenohConfig(endpoint),
                        EndpointOptions(key=key, instance="0", ticks=ticks()))
    with p1, p2:
        sub = p2.subscribe({"task.x"})
        # no warm-up: once a client's transport is open, the hub routes everything to it
        for i in range(5):
            p1.publish({"task.x"}, Bid("x", 1, "p1", float(i)))
        table = {"p1/0": p1.core.sent_count}
        tick[0] = 8
        p2.settle_tick(8, table, wait_clock=time.monotonic, give_up_after_s=30.0)
        got = sub.drain()
        assert [e.message.score for e in got] == [0.0, 1.0, 2.0, 3.0, 4.0]
        assert {e.tick for e in got} == {7}
        with pytest.raises(LostDatagrams, match=r"p1/0: 1"):
            p2.settle_tick(9, {"p1/0": p1.core.sent_count + 1}, wait_clock=time.monotonic,
                           give_up_after_s=0.5)
        assert p2.counters.dropped["lost"] == 1


def _own_sockets() -> dict[str, list[tuple[str, str]]]:
    """This process's IPv4/IPv6 sockets per table: (local, remote) hex addresses."""
    inodes = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out: dict[str, list[tuple[str, str]]] = {}
    for table in ("tcp", "tcp6", "udp", "udp6"):
        try:
            with open(f"/proc/self/net/{table}") as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            if cols[9] in inodes:
                out.setdefault(table, []).append((cols[1], cols[2]))
    return out


def test_sessions_use_only_tcp_on_127_0_0_1(trio: list[ZenohTransport]) -> None:
    sockets = _own_sockets()
    assert not sockets.get("udp") and not sockets.get("udp6"), sockets  # no scouting
    assert not sockets.get("tcp6"), sockets
    loopback = "0100007F"
    for local, remote in sockets.get("tcp", []):
        assert local.split(":")[0] == loopback, sockets
        assert remote.split(":")[0] in (loopback, "00000000"), sockets
    assert sockets.get("tcp"), "the sessions hold TCP links"


def test_endpoints_off_loopback_are_refused_unless_allowed() -> None:
    with pytest.raises(ValueError, match=r"only 127\.0\.0\.1"):
        ZenohConfig(endpoint="tcp/10.1.2.3:7447")
    with pytest.raises(ValueError, match=r"expected tcp/ADDRESS:PORT"):
        ZenohConfig(endpoint="udp/127.0.0.1:7447")
    assert parse_endpoint("tcp/10.1.2.3:7447", allow_remote=True) == ("10.1.2.3", 7447)
    settings = ZenohConfig(endpoint="tcp/127.0.0.1:7000").session_settings()
    assert settings["scouting/multicast/enabled"] is False
    assert settings["connect/endpoints"] == ["tcp/127.0.0.1:7000"]
    assert settings["listen/endpoints"] == []


def test_a_client_without_a_hub_fails_with_a_clear_error() -> None:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    with pytest.raises(OSError, match=f"cannot connect to {re.escape(endpoint)}"):
        ZenohTransport("lonely", time.monotonic,
                       ZenohConfig(endpoint=endpoint, connect_timeout_s=1.0))
