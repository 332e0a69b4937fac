"""A body's colour set while the world runs: the overhead camera's tracking and a rendering
camera see it from the next tick, and a reset restores the world file's (real PyBullet)."""

from __future__ import annotations

import numpy as np
import pytest

from player_server.sim import Simulation
from worlds import load_world, world_path


def test_overhead_tracking_and_rendered_images_see_a_new_colour() -> None:
    spec = load_world(world_path("longterm"))
    with Simulation(spec, seed=1) as sim:
        sim.step()
        before = {t.name: t.colour for t in sim.overhead()}
        sim.set_looks("p1", colour=0x123456)
        sim.step()
        after = {t.name: t.colour for t in sim.overhead()}
        assert after["p1"] == 0x123456 and before["p1"] != 0x123456
        assert {k: v for k, v in after.items() if k != "p1"} == {
            k: v for k, v in before.items() if k != "p1"}
        with pytest.raises(KeyError):
            sim.set_looks("no such body", colour=0)
        with pytest.raises(ValueError):
            sim.set_looks("p1", colour=0x1000000)
        sim.reset()
        sim.step()
        assert {t.name: t.colour for t in sim.overhead()}["p1"] == before["p1"]


def test_a_rendering_camera_sees_the_new_colour() -> None:
    spec = load_world(world_path("longterm"))
    viewer = next(r for r in spec.robots if r.devices.camera is not None)
    other = next(r for r in spec.robots if r is not viewer)
    with Simulation(spec, seed=1, fidelity="render") as sim:
        x, y, yaw = sim.get_pose(viewer.name)
        # the other robot 1 m straight ahead of the camera, filling the middle of the image
        sim.set_pose(other.name, x + np.cos(yaw), y + np.sin(yaw), yaw)
        sim.step()

        def share(rgb: int) -> float:
            img = sim.camera_image(viewer.name)[..., :3].astype(int)
            want = np.array([(rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255])
            return float((np.abs(img - want).max(axis=-1) < 20).mean())

        assert share(0x00FF00) < 0.01
        sim.set_looks(other.name, colour=0x00FF00)
        sim.step()
        assert share(0x00FF00) > 0.05
