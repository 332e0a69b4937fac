"""Unchanged values are handed out again as the same objects: snapshots and the overhead view
re-use the poses of bodies that have not moved, range readings and blobs are the same objects
while they are unchanged, drivers and the server core re-use what they made of them. What is
reported must always equal what a fresh computation gives, tick after tick."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from player_server.protocol.codec import encode_message
from player_server.server.assembly import world_endpoints
from player_server.server.core import ServerCore
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


def test_unchanged_readings_are_the_same_objects_and_equal_fresh_ones() -> None:
    spec = load_world(world_path("longterm"))
    sim = Simulation(spec, seed=3)
    twin = Simulation(spec, seed=3)  # forgets its last readings every tick
    names = sim.robot_names()
    try:
        ranged = [n for n in names if sim.spec.robot(n).devices.sonar is not None]
        cams = [n for n in names if sim.spec.robot(n).devices.blobfinder is not None]
        assert ranged and cams
        still = moved = still_blobs = 0
        before: dict[tuple[str, str], object] = {}
        for tick in range(80):
            moving = names[0] if (tick // 20) % 2 else None
            for s in (sim, twin):
                for n in names:
                    s.set_velocity(n, 0.4 if n == moving else 0.0, 0.3 if n == moving else 0.0)
                s.step()
            twin.range_model.last.clear()  # the twin computes every reading afresh
            twin.camera_model.last.clear()
            for n in ranged:
                got, want = sim.sonar(n), twin.sonar(n)
                assert np.array_equal(got, want) and got.dtype == want.dtype
                if (n, "sonar") in before and before[(n, "sonar")] is got:
                    still += 1
                before[(n, "sonar")] = got
            for n in cams:
                got_b = sim.blobs(n)
                assert got_b == twin.blobs(n)
                assert list(got_b) == sorted(got_b, key=lambda b: (b.id, -b.area, b.x))
                prev = before.get((n, "blobs"))
                if prev is not None and prev != got_b:
                    moved += 1
                    assert prev is not got_b
                elif prev is not None:  # the same blobs: the same tuple, nothing made again
                    assert prev is got_b
                    still_blobs += got_b != ()
                before[(n, "blobs")] = got_b
        assert still > 0 and moved > 0 and still_blobs > 0
    finally:
        sim.close()
        twin.close()


def test_server_data_equals_fresh_encoding_while_robots_stand_and_move() -> None:
    spec = load_world(world_path("longterm"))
    sim = Simulation(spec, seed=5)
    endpoints = world_endpoints(spec, sim, 0)
    core = ServerCore(endpoints, lambda: float(sim.time_s))
    names = sim.robot_names()
    skip = {"camera", "fiducial", "simulation"}
    try:
        for tick in range(60):
            for i, n in enumerate(names):  # one robot at a time moves, the others stand
                go = i == (tick // 10) % len(names)
                sim.set_velocity(n, 0.4 if go else 0.0, -0.5 if go else 0.0)
            sim.step()
            fresh_eps = world_endpoints(spec, sim, 0)  # drivers with no memory
            for ep, fresh in zip(endpoints, fresh_eps, strict=True):
                for key, driver in ep.drivers.items():
                    if driver.driver_name.split("_")[-1] in skip or "camera" in driver.driver_name:
                        continue
                    got = core._device_data(ep, key, driver)
                    want = [encode_message(key[0], key[1], 1, sub, body,
                                           timestamp=sim.time_s, robot=ep.port)
                            for sub, body in fresh.drivers[key].data()]
                    assert [w for _, w in got] == want, (ep.name, driver.driver_name)
    finally:
        sim.close()
