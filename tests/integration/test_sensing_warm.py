"""The server compiles the sensing kernels when it starts, not in the first round a client
waits for: `Simulation.warm` (called by `PlayerServer.start`) compiles every kernel with the
argument types the real sensing pass uses, and keeps nothing of what it computed.

Run in a fresh interpreter, so that no earlier test has compiled a kernel already."""

from __future__ import annotations

import json
import subprocess
import sys

SCRIPT = r"""
import json
from player_server.sim import Simulation
from player_server.sim import blob_kernel, cast_kernel
from worlds.loader import load_world, world_path

kernels = {"cast_rays": cast_kernel.cast_rays, "cast_rays_grid": cast_kernel.cast_rays_grid,
           "pending_near": blob_kernel.pending_near, "blob_boxes": blob_kernel.blob_boxes}
def signatures():
    return {name: [str(s) for s in k.signatures] for name, k in kernels.items()}

sim = Simulation(load_world(world_path("longterm")), seed=2)
before = signatures()
sim.warm()
warmed = signatures()
kept = {"active_ranges": len(sim.range_model.reads.known()),
        "active_cams": len(sim.camera_model.reads.known()),
        "cached": sim.sensed_now() is not None}
# the real pass: every robot's range sensors and blobfinder read over a few ticks
for _ in range(3):
    for name in sim.robot_names():
        devices = sim.spec.robots[sim.robot_names().index(name)].devices
        for kind in ("sonar", "laser", "ranger"):
            if getattr(devices, kind) is not None:
                sim.range_model.reading(name, kind)
        if devices.blobfinder is not None:
            sim.camera_model.blobs(name)
    sim.step()
print(json.dumps({"before": before, "warmed": warmed, "used": signatures(), "kept": kept}))
sim.close()
"""


def test_warm_compiles_every_kernel_with_the_types_the_sensing_pass_uses() -> None:
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert all(not sigs for sigs in got["before"].values()), got["before"]
    assert all(got["warmed"].values()), got["warmed"]  # every kernel, the grid cast included
    # reading every sensor for real compiled nothing more
    assert got["used"] == got["warmed"]
    assert got["kept"] == {"active_ranges": 0, "active_cams": 0, "cached": False}
