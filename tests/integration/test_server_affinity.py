"""The serving thread pins itself to the CPUs it is given; what the runner starts after pinning
itself to the other CPUs (threads, robot processes) stays there."""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

import pytest

from experiments.run_cli import RobotProcess, _start_robot, _stop_robot
from player_server.server.affinity import (
    CpuSplit,
    allowed_cpus,
    pin_current_thread,
    plan_split,
)
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(60)

CPUS = allowed_cpus()
needs_two = pytest.mark.skipif(CPUS is None or len(CPUS) < 2,
                               reason="needs CPU affinity and at least two CPUs")


def test_plan_split() -> None:
    assert plan_split([0]) is None and plan_split([]) is None
    assert plan_split([3, 1, 2, 1]) == CpuSplit(frozenset({3}), frozenset({1, 2}))
    assert plan_split(range(2)).as_dict() == {"serving": [1], "others": [0]}  # type: ignore[union-attr]


@needs_two
def test_serving_thread_and_children_keep_apart(tmp_path: Path) -> None:
    assert CPUS is not None
    split = plan_split(CPUS)
    assert split is not None
    seen: dict[str, object] = {}

    def runner_thread() -> None:  # stands in for the runner's main thread
        assert pin_current_thread(split.others)
        spec = load_world(world_path("simple"))
        sim = Simulation(spec)
        server = PlayerServer(sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s,
                              clock=time.monotonic, speedup=0.0,
                              config=CoreConfig(lockstep=True), cpus=split.serving)
        rp = RobotProcess("r1", 0)
        try:
            server.start()
            tid = server.thread_id
            assert tid is not None
            deadline = time.monotonic() + 10.0
            while os.sched_getaffinity(tid) != split.serving and time.monotonic() < deadline:
                time.sleep(0.01)
            seen["serving"] = os.sched_getaffinity(tid)
            seen["runner"] = os.sched_getaffinity(0)
            _start_robot(rp, [sys.executable, "-c", "import time; time.sleep(20)"],
                         tmp_path / "r1.log")
            assert rp.proc is not None
            seen["robot"] = os.sched_getaffinity(rp.proc.pid)
        finally:
            _stop_robot(rp)
            server.stop()
            sim.close()

    t = threading.Thread(target=runner_thread)
    t.start()
    t.join(30.0)
    assert not t.is_alive()
    assert seen == {"serving": split.serving, "runner": split.others, "robot": split.others}
    assert os.sched_getaffinity(0) == CPUS  # the test's own thread was never pinned
