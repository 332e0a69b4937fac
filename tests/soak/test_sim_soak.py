"""Opt-in (pytest -m soak): an hour of the longterm world stays physically sane."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest

from player_server.sim import Simulation
from player_server.sim.demo import WanderDriver
from worlds import load_world, world_path


@pytest.mark.soak
@pytest.mark.timeout(1800)
def test_longterm_hour_stays_sane() -> None:
    spec = load_world(world_path("longterm"))
    with Simulation(spec) as sim:
        driver = WanderDriver(sim, np.random.default_rng(1), sense_all=True)
        worst_z = 0.0
        for i in range(36000):
            driver.tick()
            if i % 50 == 0:
                for r in spec.robots:
                    # Robots glide at their height: contacts do not lift them for long.
                    z = pb.getBasePositionAndOrientation(sim.ids.robots[r.name],
                                                         physicsClientId=sim.physics_client)[0][2]
                    worst_z = max(worst_z, abs(z - (r.body.height_m / 2 + 0.001)))
        assert worst_z < 0.05
        hx, hy = spec.arena.half_x_m, spec.arena.half_y_m
        for body in sim.snapshot().bodies:
            assert math.isfinite(body.x) and math.isfinite(body.y)
            assert abs(body.x) < hx and abs(body.y) < hy, body
        assert sum(driver.stats.charge_trips.values()) >= 2
