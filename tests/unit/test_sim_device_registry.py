"""Every device a world file can declare has a simulator model and a Player driver, each found
in its package (nothing lists them), the models in the order the world advances them."""

from __future__ import annotations

import pytest

from player_server.drivers.registry import _BY_DEVICE
from player_server.sim import Simulation
from player_server.sim.devices import DEVICE_MODELS, MODEL_CLASSES
from worlds import load_world, world_path
from worlds.device_kinds import device_kinds
from worlds.spec import DEVICE_NAMES


def test_each_declarable_device_has_a_model_and_a_driver() -> None:
    kinds = device_kinds()
    assert list(kinds)[:len(DEVICE_NAMES)] == list(DEVICE_NAMES)
    assert set(kinds) == set(DEVICE_MODELS)
    assert set(kinds) == set(_BY_DEVICE)
    assert all(_BY_DEVICE[k].device == k for k in kinds)
    assert len({k for cls in MODEL_CLASSES for k in cls.kinds}) == sum(
        len(cls.kinds) for cls in MODEL_CLASSES), "a device kind has two models"


def test_the_models_keep_their_order() -> None:
    """Power reads this tick's drive, so it advances after position2d; the built-ins keep the
    order that the runs' digests were recorded with."""
    names = [cls.__name__ for cls in MODEL_CLASSES]
    assert names[:8] == ["Position2dModel", "PowerModel", "GripperModel", "PtzModel",
                         "BumperModel", "RangeModel", "CameraModel", "TrackingModel"]


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
