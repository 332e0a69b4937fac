"""Every device a world file can declare has a simulator model and a Player driver."""

from __future__ import annotations

import pytest

from player_server.drivers.registry import _BY_DEVICE
from player_server.sim import Simulation
from player_server.sim.devices import DEVICE_MODELS, MODEL_CLASSES
from worlds import load_world, world_path
from worlds.spec import DEVICE_NAMES


def test_each_declarable_device_has_a_model_and_a_driver() -> None:
    assert set(DEVICE_NAMES) <= set(DEVICE_MODELS)
    assert set(DEVICE_NAMES) <= set(_BY_DEVICE)
    assert len({k for cls in MODEL_CLASSES for k in cls.kinds}) == sum(
        len(cls.kinds) for cls in MODEL_CLASSES), "a device kind has two models"


@pytest.mark.parametrize("fidelity", ["fast", "render"])
def test_the_world_builds_and_advances_one_model_of_each_class(fidelity: str) -> None:
    sim = Simulation(load_world(world_path("longterm")), seed=1, fidelity=fidelity)
    try:
        assert [type(m) for m in sim.models] == list(MODEL_CLASSES)
        for cls in MODEL_CLASSES:
            assert type(sim.model(cls)) is cls
        name = next(r.name for r in sim.spec.robots if r.devices.sonar is not None)
        sim.set_velocity(name, 0.2, 0.0)
        sim.step(5)
        assert sim.sonar(name).size == len(sim.spec.robot(name).devices.sonar.poses)
        assert sim.odometry(name).x > 0.0
        before = sim.power(name).percent
        sim.set_battery(name, 0.5)
        assert sim.power(name).percent < before
        sim.reset()
        assert sim.tick == 0 and sim.odometry(name).x == 0.0
    finally:
        sim.close()
