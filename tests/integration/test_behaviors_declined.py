"""A robot's I/O opens every device of its port but declines the DATA nobody reads.

Real server in this process (the long-term world, paced), real TCP on loopback: the overhead
camera's port has a blobfinder, a fiducial detector and a camera; the robot I/O subscribes to
all of them, and only blobs arrive (images only with ``subscribe_images``).
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from behaviors.sensing import PlayerRobotIO
from player_server.client import PlayerClient
from player_server.server.assembly import world_endpoints
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(60)


@pytest.fixture(scope="module")
def server() -> Iterator[PlayerServer]:
    spec = load_world(world_path("longterm"))
    sim = Simulation(spec, seed=1)
    srv = PlayerServer(sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s,
                       clock=time.monotonic, speedup=20.0)
    srv.start()
    try:
        yield srv
    finally:
        srv.stop()


def _rounds(client: PlayerClient, n: int) -> None:
    for _ in range(n):
        client.read(timeout_s=10.0)


@pytest.mark.parametrize("images", [False, True])
def test_unread_devices_are_subscribed_but_send_nothing(server: PlayerServer,
                                                        images: bool) -> None:
    with PlayerClient("127.0.0.1", server.ports["desktop"], timeout_s=5.0,
                      read_timeout_s=10.0) as client:
        io = PlayerRobotIO(client, subscribe_images=images)
        io.open()
        assert {"blobfinder", "fiducial", "camera"} <= set(io.proxies)
        _rounds(client, 5)
        assert io.proxies["blobfinder"].data_count >= 5
        assert io.proxies["fiducial"].data_count == 0
        assert (io.proxies["camera"].data_count >= 5) is images
