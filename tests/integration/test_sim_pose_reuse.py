"""Snapshots and the overhead view re-use the values of bodies that have not moved; what they
report must equal what a fresh reading of every pose gives, tick after tick."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from player_server.sim import Simulation
from player_server.sim.readings import Blob, BodyPose, fast_constructor
from worlds import load_world, world_path


def test_fast_constructor_builds_equal_frozen_values() -> None:
    make = fast_constructor(Blob)
    a, b = make(1, 0xFF0000, 4, 1, 2, 0, 2, 0, 3, 1.5), Blob(1, 0xFF0000, 4, 1, 2, 0, 2, 0, 3, 1.5)
    assert a == b and hash(a) == hash(b) and repr(a) == repr(b)
    assert dataclasses.astuple(a) == dataclasses.astuple(b)
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.area = 5  # type: ignore[misc]
    assert make(2, 0, 1, 1, 1, 1, 1, 1, 1, 0.5) != b


def test_snapshot_and_overhead_follow_every_move() -> None:
    sim = Simulation(load_world(world_path("longterm")), seed=3)
    rng = np.random.default_rng(11)
    names = sim.robot_names()
    things = [n for n in sim.body_names() if n not in names]
    cam = sim.spec.overhead_camera
    assert cam is not None
    try:
        prev: dict[str, BodyPose] = {}
        for tick in range(120):
            for i, n in enumerate(names):
                sim.set_velocity(n, 0.3 * ((i + tick // 40) % 2), 0.4 * ((i % 3) - 1))
            if tick % 17 == 5:  # teleport a thing, sometimes out of the camera's view
                name = things[int(rng.integers(len(things)))]
                far = tick % 34 == 5
                sim.set_pose(name, float(rng.uniform(-5, 5)) + (40.0 if far else 0.0),
                             float(rng.uniform(-4, 4)), float(rng.uniform(-math.pi, math.pi)))
            if tick % 23 == 7:  # a move along one coordinate only
                name = things[int(rng.integers(len(things)))]
                x, y, yaw = sim.get_pose(name)
                if tick % 46 == 7:
                    sim.set_pose(name, x, y + 0.5, yaw)
                else:
                    sim.set_pose(name, x, y, yaw + 0.5)
            sim.step()
            snap = sim.snapshot()
            got = {b.name: (b.kind, b.x, b.y, b.yaw) for b in snap.bodies}
            for name, (kind, x, y, yaw) in got.items():
                assert (x, y, yaw) == pytest.approx(sim.get_pose(name), abs=1e-12), name
                assert kind == ("robot" if name in names else kind)
            for b in snap.bodies:  # an unmoved body keeps its object; a moved one does not
                old = prev.get(b.name)
                if old is not None:
                    assert (old is b) == ((old.x, old.y, old.yaw) == (b.x, b.y, b.yaw))
            prev = {b.name: b for b in snap.bodies}
            seen = {t.name: t for t in sim.overhead()}
            want = {b.name for b in snap.bodies
                    if abs(b.x - cam.x) <= cam.view_size_x_m / 2
                    and abs(b.y - cam.y) <= cam.view_size_y_m / 2}
            assert set(seen) == want
            for name, t in seen.items():
                assert (t.x, t.y, t.yaw) == (got[name][1], got[name][2], got[name][3])
                assert t.kind == got[name][0]
    finally:
        sim.close()
