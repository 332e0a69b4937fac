"""Many robots in one world: a generated 1,000-robot world loads and steps with every robot
sensing, and the grid-walking caster gives the simulation the same readings as testing every
footprint."""

from __future__ import annotations

import copy
import hashlib
import tomllib
from pathlib import Path

import numpy as np

from player_server.sim import Simulation
from player_server.sim.cast_kernel import CompiledCaster
from player_server.sim.demo import WanderDriver
from worlds import parse_world, world_path


def _generated(n: int, seed: int) -> object:
    data = tomllib.loads(world_path("swarm100").read_text(encoding="utf-8"))
    data = copy.deepcopy(data)
    data["generate"].update(robots=n, objects=n // 3, boxes=n // 10, seed=seed)
    return parse_world(data, Path(f"swarm{n}.toml"))


def test_a_thousand_generated_robots_step_and_sense() -> None:
    spec = _generated(1000, seed=2)
    with Simulation(spec, fidelity="fast") as sim:
        driver = WanderDriver(sim, np.random.default_rng(0), sense_all=True)
        for _ in range(3):
            driver.tick()
        assert sim.tick == 3
        sentries = [r.name for r in spec.robots if r.devices.laser is not None]
        lasers = [sim.laser(n) for n in sentries]
        assert all(r.shape == (181,) and np.all(r > 0) for r in lasers)
        # robots stand about 2.4 m apart: most lasers see a neighbour well short of 8 m
        assert np.median([r.min() for r in lasers]) < 4.0
        sonars = np.array([sim.sonar(r.name) for r in spec.robots])
        assert sonars.shape == (1000, 16) and np.all(np.isfinite(sonars))
        seen = sum(len(sim.blobs(r.name)) for r in spec.robots)
        assert seen > 100  # balls, boxes and chargers are in view of many cameras
        assert len(sim.overhead()) >= 1000


def _digest(spec: object, grid_min: int, ticks: int) -> str:
    h = hashlib.sha256()
    with Simulation(spec, fidelity="fast") as sim:
        sim.sensing.caster = CompiledCaster(grid_min=grid_min)
        driver = WanderDriver(sim, np.random.default_rng(4), sense_all=True)
        for _ in range(ticks):
            driver.tick()
            for r in spec.robots:  # type: ignore[attr-defined]
                d = r.devices
                h.update(sim.sonar(r.name).tobytes())
                if d.laser is not None:
                    h.update(sim.laser(r.name).tobytes())
                h.update(repr(sim.blobs(r.name)).encode())
                h.update(repr(sim.get_pose(r.name)).encode())
    return h.hexdigest()


def test_grid_and_every_footprint_give_the_same_run() -> None:
    spec = _generated(60, seed=9)
    assert _digest(spec, 0, 40) == _digest(spec, 10**9, 40)
