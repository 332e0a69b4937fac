"""Serving a Stage .cfg in the test process: the simulation, its server and a client of robot1.

Shared by the Stage integration tests (charging, laser fans, properties, the example world)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from player_server.client import PlayerClient
from player_server.server.runner import PlayerServer
from player_server.server.stage_assembly import plan_endpoints
from player_server.server.stage_source import load_stage_source
from player_server.sim import Simulation


@contextmanager
def serve(path: Path, *, world_control: bool = False) -> Iterator[tuple[PlayerServer, list]]:
    """The .cfg at `path` served on ephemeral ports at ten times real time, then stopped."""
    world, plan = load_stage_source(str(path), 0)
    sim = Simulation(world.spec, seed=1)
    endpoints = plan_endpoints(plan, world, sim, allow_world_control=world_control,
                               ephemeral=True)
    server = PlayerServer(sim, endpoints, interval_s=sim.interval_s, clock=time.monotonic,
                          speedup=10.0)
    try:
        server.start()
        yield server, plan.ports()
    finally:
        server.stop()
        sim.close()


@contextmanager
def robot1(path: Path, *, world_control: bool = False) -> Iterator[PlayerClient]:
    """A client connected to robot1 of the .cfg at `path`, served as `serve` does."""
    with serve(path, world_control=world_control) as (server, _), \
            PlayerClient("127.0.0.1", server.ports["robot1"], timeout_s=10.0,
                         read_timeout_s=10.0) as cl:
        yield cl
