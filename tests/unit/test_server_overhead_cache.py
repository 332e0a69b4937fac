"""The overhead drivers re-use the blob and fiducial of a thing that has not moved: what they
send must be exactly what a driver without that memory computes."""

from __future__ import annotations

import random
from types import SimpleNamespace

from player_server.drivers.overhead import OverheadBlobfinderDriver, OverheadFiducialDriver
from player_server.sim.readings import TrackedObject


class MovingScene:
    """Only what the overhead drivers read: ``overhead()``, changed by `move`."""

    def __init__(self, things: list[TrackedObject]) -> None:
        self.things = things

    def overhead(self) -> tuple[TrackedObject, ...]:
        return tuple(self.things)


def _world() -> SimpleNamespace:
    cam = SimpleNamespace(name="desk", x=0.5, y=-0.25, height_m=4.0, view_size_x_m=8.0,
                          view_size_y_m=6.0, width_px=320, height_px=240, position_noise_m=0.0)
    body = SimpleNamespace(width_m=0.4, length_m=0.5)
    return SimpleNamespace(
        overhead_camera=cam,
        robots=[SimpleNamespace(name=f"r{i}", fiducial_id=i + 1, body=body) for i in range(3)],
        objects=[SimpleNamespace(name="can", fiducial_id=9, radius_m=0.1)],
        boxes=[SimpleNamespace(name="box", size_x_m=0.6, size_y_m=0.4)],
        markers=[])


def test_remembered_things_give_what_a_fresh_driver_computes() -> None:
    rng = random.Random(7)
    world = _world()
    names = ["r0", "r1", "r2", "can", "box", "stranger"]
    pool = {n: TrackedObject(n, "robot", rng.randrange(1 << 25), rng.uniform(-5, 5),
                             rng.uniform(-4, 4), 0.0) for n in names}
    present = set(names)
    scene = MovingScene([pool[n] for n in names])
    blobs = OverheadBlobfinderDriver(scene, world)
    fids = OverheadFiducialDriver(scene, world)
    seen = shifted = 0
    for _ in range(300):
        for n, t in pool.items():  # some stand still, some move (in and out of view)
            if rng.random() < 0.3:
                pool[n] = TrackedObject(n, t.kind, t.colour, rng.uniform(-5, 5),
                                        rng.uniform(-4, 4), rng.uniform(-3, 3))
        if rng.random() < 0.2:  # one disappears (picked up) or comes back: indices shift
            present ^= {rng.choice(names)}
            shifted += 1
        scene.things = [pool[n] for n in names if n in present]
        assert blobs.data() == OverheadBlobfinderDriver(scene, world).data()
        assert fids.data() == OverheadFiducialDriver(scene, world).data()
        seen += len(blobs.data()[0][1].blobs)
    assert shifted > 10
    assert 0 < seen < 300 * len(names)  # some in view, some out
