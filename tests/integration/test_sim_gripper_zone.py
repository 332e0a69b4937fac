"""The gripper's zone test (which object lies between the paddles) against a plain
per-object reading of its definition, on generated worlds with few objects (one cell) and
with many (a grid), robots placed all around objects, real PyBullet."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from player_server.sim import Simulation
from player_server.sim.devices.gripper import GripperModel
from worlds import world_path
from worlds.loader import parse_world


def _reference(sim: Simulation, robot: str) -> str | None:
    """Every object tested one by one: nearest to the paddles' line wins, the first in
    world-file order among equals."""
    st = sim.device(robot, "gripper")
    g = st.spec.devices.gripper
    assert g is not None
    c, s = math.cos(st.yaw), math.sin(st.yaw)
    best, best_d = None, math.inf
    for o in sim.spec.objects:
        if o.name in sim.hidden or o.name in sim.held or o.radius_m > g.max_object_radius_m:
            continue
        x, y, _ = sim.get_pose(o.name)
        wx, wy = x - st.x, y - st.y
        lx, ly = c * wx + s * wy, -s * wx + c * wy
        d = abs(lx - g.pose.x)
        if abs(ly) <= g.width_m / 2 and d <= g.depth_m / 2 + o.radius_m and d < best_d:
            best, best_d = o.name, d
    return best


@pytest.mark.parametrize("objects", [40, 120])
def test_the_zone_is_the_nearest_object_between_the_paddles(objects: int) -> None:
    path = world_path("swarm100")
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["generate"]["objects"] = objects
    data["generate"]["area_per_robot"] = 9.0  # room for the extra objects
    spec = parse_world(data, path)
    assert len(spec.objects) == objects
    sim = Simulation(spec, fidelity="fast")
    try:
        model = sim.model(GripperModel)
        grippers = [r.name for r in spec.robots if r.devices.gripper is not None][:6]
        assert grippers
        rng = np.random.default_rng(5)
        hits = checked = 0
        for round_ in range(12):
            for i, robot in enumerate(grippers):
                o = spec.objects[(round_ * len(grippers) + i) % len(spec.objects)]
                ox, oy, _ = sim.get_pose(o.name)
                yaw = float(rng.uniform(-math.pi, math.pi))
                gap = float(rng.uniform(0.0, 0.6))
                side = float(rng.uniform(-0.15, 0.15))
                x = ox - gap * math.cos(yaw) + side * math.sin(yaw)
                y = oy - gap * math.sin(yaw) - side * math.cos(yaw)
                sim.set_pose(robot, x, y, yaw)
            sim.step()
            for robot in grippers:
                want = _reference(sim, robot)
                got = model._grip_zone(sim.device(robot, "gripper"))
                assert got == want, (robot, round_)
                hits += want is not None
                checked += 1
        assert checked == 72 and 0 < hits < checked  # both outcomes were exercised
    finally:
        sim.close()
