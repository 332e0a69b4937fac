"""Fuzzing a live server: random frames never crash it nor disturb another client."""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from player_server.client import LaserProxy, PlayerClient, Position2dProxy
from player_server.protocol import encode_message
from player_server.protocol.common import DevAddr
from player_server.protocol.player_msgs import DeviceDatamodeReq, DeviceReq
from player_server.protocol.registry import REGISTRY
from player_server.server.assembly import world_endpoints
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(120)

HEADER = struct.Struct(">IIIIIIdII")
KEYS = sorted(REGISTRY)


@pytest.fixture(scope="module")
def live() -> Iterator[tuple[PlayerServer, PlayerClient]]:
    spec = load_world(world_path("simple"))
    sim = Simulation(spec)
    # paced, so that the serving thread leaves this process's interpreter lock to the test
    server = PlayerServer(sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s,
                          clock=time.monotonic, speedup=20.0)
    server.start()
    observer = PlayerClient("127.0.0.1", server.ports["robot1"]).connect()
    observer.subscribe(LaserProxy)
    observer.subscribe(Position2dProxy)
    try:
        yield server, observer
    finally:
        observer.close()
        server.stop()
        sim.close()


frame_from_table = st.builds(
    lambda key, index, body: HEADER.pack(0, 0, key[0], index, key[1], key[2], 0.0, 0,
                                         len(body)) + body,
    st.sampled_from(KEYS), st.integers(0, 2), st.binary(max_size=64))
frame_random = st.builds(
    lambda interf, index, t, sub, body: HEADER.pack(0, 0, interf, index, t, sub, 0.0, 0,
                                                    len(body)) + body,
    st.sampled_from([1, 2, 3, 4, 5, 6, 7, 8, 10, 14, 31, 40, 62, 99, 65535]),
    st.integers(0, 3), st.integers(0, 8), st.integers(0, 255), st.binary(max_size=64))
subscribe = st.sampled_from([
    encode_message(1, 0, 3, 3, DeviceReq(DevAddr(0, 0, i, 0), 1, "")) for i in (4, 5, 6, 31, 62)
] + [encode_message(1, 0, 3, 4), encode_message(1, 0, 3, 5, DeviceDatamodeReq(2))])
frames = st.lists(st.one_of(frame_from_table, frame_random, subscribe), min_size=1,
                  max_size=12)


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(frames, st.binary(max_size=30))
def test_live_fuzz(live: tuple[PlayerServer, PlayerClient], batch: list[bytes],
                   tail: bytes) -> None:
    server, observer = live
    fuzz_sock = socket.create_connection(("127.0.0.1", server.ports["robot1"]), timeout=5)
    try:
        fuzz_sock.recv(32)
        fuzz_sock.sendall(b"".join(batch) + tail)
    except OSError:
        pass  # the server may close a connection that sent garbage
    finally:
        fuzz_sock.close()
    updated = observer.read(timeout_s=10)
    assert len(updated) == 2
    assert server.error is None and not server.finished.is_set()
