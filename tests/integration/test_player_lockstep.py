"""Lockstep: robot processes of different speeds see every tick; a seeded run repeats."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from player_server.client import PlayerClient, PlayerTimeout, Position2dProxy, SonarProxy
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(120)

TICKS = 40

ROBOT = """
import sys, time
from player_server.client import PlayerClient, PlayerTimeout, Position2dProxy, SonarProxy
port, n, delay_s, out = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
cl = PlayerClient("127.0.0.1", port, read_timeout_s=30.0).connect()
pos = cl.subscribe(Position2dProxy)
sonar = cl.subscribe(SonarProxy)
lines = []
for i in range(n):
    cl.read()
    front = min(sonar.ranges[2:6])
    lines.append(f"{pos.data_time_s:.3f} {pos.x:.9f} {pos.y:.9f} {pos.yaw:.9f} {front:.6f}")
    v, w = (0.4, 0.05) if front > 0.7 else (0.0, 0.8)
    pos.set_velocity(v, w)
    if delay_s:
        time.sleep(delay_s * (i % 3))
cl.close()
open(out, "w").write("\\n".join(lines) + "\\n")
"""


def run_once(tmp: Path, delays: tuple[float, float], tag: str,
             pipelined: bool = False) -> tuple[str, str, int]:
    spec = load_world(world_path("boxpush"))
    sim = Simulation(spec, seed=11)
    server = PlayerServer(
        sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s, clock=time.monotonic,
        speedup=0.0,
        config=CoreConfig(lockstep=True, lockstep_clients=2, lockstep_timeout_s=20.0,
                          pipelined=pipelined),
    )
    server.start()
    try:
        # a monitor on the watcher port must neither hold nor advance the clock
        with PlayerClient("127.0.0.1", server.ports["watcher"], lockstep=False) as monitor:
            monitor.subscribe(SonarProxy)
            outs = [tmp / f"{tag}_{name}.txt" for name in ("pusher1", "pusher2")]
            procs = [
                subprocess.Popen([sys.executable, "-c", ROBOT, str(server.ports[name]),
                                  str(TICKS), str(delay), str(out)])
                for name, delay, out in zip(("pusher1", "pusher2"), delays, outs, strict=True)
            ]
            monitor.read(timeout_s=10)
            for p in procs:
                assert p.wait(timeout=60) == 0
            monitor.read(timeout_s=10)
            assert not monitor.is_lockstep_participant()
        ticks = server.ticks
    finally:
        server.stop()
        sim.close()
    return outs[0].read_text(), outs[1].read_text(), ticks


@pytest.mark.parametrize("pipelined", [False, True], ids=["lockstep", "pipelined"])
def test_two_robot_processes_repeat_exactly(tmp_path: Path, pipelined: bool) -> None:
    a1, b1, ticks1 = run_once(tmp_path, (0.0, 0.01), "first", pipelined)
    a2, b2, ticks2 = run_once(tmp_path, (0.01, 0.0), "second", pipelined)
    for text in (a1, b1):
        stamps = [float(line.split()[0]) for line in text.splitlines()]
        assert stamps == pytest.approx([0.1 * i for i in range(TICKS)])  # every tick, none twice
    assert a1 == a2 and b1 == b2
    assert a1 != b1
    assert ticks1 == ticks2 == TICKS - 1


def _poses_after_one_command(pipelined: bool) -> list[float]:
    """x of a robot over 4 rounds; after round 0 it is told to drive (and never again)."""
    spec = load_world(world_path("simple"))
    sim = Simulation(spec, seed=1)
    server = PlayerServer(
        sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s, clock=time.monotonic,
        speedup=0.0, config=CoreConfig(lockstep=True, pipelined=pipelined))
    server.start()
    try:
        with PlayerClient("127.0.0.1", server.ports["robot1"], read_timeout_s=20.0) as cl:
            pos = cl.subscribe(Position2dProxy)
            xs = []
            for i in range(4):
                cl.read()
                xs.append(pos.x)
                pos.set_velocity(0.5 if i < 2 else 0.0, 0.0)
    finally:
        server.stop()
        sim.close()
    return xs


def test_pipelined_commands_act_one_tick_later() -> None:
    plain = _poses_after_one_command(False)
    piped = _poses_after_one_command(True)
    assert plain[2] > plain[1] > plain[0]
    # the same start: the first step of both already has the first command
    assert piped[:3] == plain[:3]
    # the stop sent after round 2 shapes round 3 at once in plain lockstep; pipelined, the
    # step to round 3 was taken before it arrived, still at full speed
    assert piped[3] > plain[3]


def test_simulation_waits_for_the_expected_clients() -> None:
    spec = load_world(world_path("boxpush"))
    sim = Simulation(spec, seed=1)
    server = PlayerServer(
        sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s, clock=time.monotonic,
        speedup=0.0, config=CoreConfig(lockstep=True, lockstep_clients=2))
    server.start()
    try:
        with PlayerClient("127.0.0.1", server.ports["pusher1"]) as cl:
            pos = cl.subscribe(Position2dProxy)
            assert cl.is_lockstep_participant()
            cl.read()
            with pytest.raises(PlayerTimeout):
                cl.read(timeout_s=0.5)  # the second robot is not there yet
            assert pos.data_time_s == 0.0 and server.ticks == 0
    finally:
        server.stop()
        sim.close()


def test_a_participant_leaving_releases_the_clock() -> None:
    spec = load_world(world_path("boxpush"))
    sim = Simulation(spec, seed=2)
    server = PlayerServer(
        sim, world_endpoints(spec, sim, 0), interval_s=sim.interval_s, clock=time.monotonic,
        speedup=0.0, config=CoreConfig(lockstep=True, lockstep_clients=2))
    stamps: dict[str, list[float]] = {"pusher1": [], "pusher2": []}
    errors: list[BaseException] = []

    def robot(name: str, reads: int) -> None:
        try:
            with PlayerClient("127.0.0.1", server.ports[name], read_timeout_s=20.0) as cl:
                pos = cl.subscribe(Position2dProxy)
                for _ in range(reads):
                    cl.read()
                    stamps[name].append(pos.data_time_s or 0.0)
        except BaseException as exc:  # seen by the test
            errors.append(exc)

    server.start()
    try:
        threads = [threading.Thread(target=robot, args=("pusher1", 5)),
                   threading.Thread(target=robot, args=("pusher2", 15))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        assert not any(t.is_alive() for t in threads) and not errors
    finally:
        server.stop()
        sim.close()
    assert stamps["pusher1"] == pytest.approx([0.1 * i for i in range(5)])
    assert stamps["pusher2"] == pytest.approx([0.1 * i for i in range(15)])
