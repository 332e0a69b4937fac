"""Robots doing the paper's tasks against the real server, over loopback, in lockstep.

The server runs as a real `player-server` process (ephemeral ports, lockstep, speedup 0);
robots are real `murdoch-robot` processes, or (for the box push, which needs a task
allocator in the loop) `RobotAgent`s built with the Python API in this process. The test
reads ground truth through the simulation device with a non-lockstep observer client.
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

from behaviors.agent import RobotAgent
from behaviors.events import Event, EventLog
from behaviors.robot import build_agent
from player_server.client import PlayerClient, SimulationProxy
from worlds import load_world, world_path

BIN = Path(sys.executable).parent
HOST = "127.0.0.1"


@dataclass
class Server:
    proc: subprocess.Popen[str]
    ports: dict[str, int]


def _start_server(world: str, robots: int, seed: int = 1, lockstep: bool = True,
                  speedup: float = 0.0) -> Server:
    pacing = ["--lockstep", "--lockstep-clients", str(robots)] if lockstep else []
    proc = subprocess.Popen(
        [str(BIN / "player-server"), world, "-p", "0", *pacing, "--speedup", str(speedup),
         "--seed", str(seed), "--allow-world-control", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    ports: dict[str, int] = {}
    spec = load_world(world_path(world))
    expected = len(spec.robots) + (spec.overhead_camera is not None)
    deadline = time.monotonic() + 30.0
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        parts = line.split()
        if len(parts) >= 2 and parts[1].isdigit():
            ports[parts[0]] = int(parts[1])
            if len(ports) >= expected:
                break
    if len(ports) < expected:
        proc.kill()
        proc.wait(5)
        raise RuntimeError(f"server did not report its ports: {ports}")
    return Server(proc, ports)


@contextmanager
def server(world: str, robots: int, seed: int = 1, lockstep: bool = True,
           speedup: float = 0.0) -> Iterator[Server]:
    srv = _start_server(world, robots, seed, lockstep, speedup)
    try:
        yield srv
    finally:
        srv.proc.send_signal(signal.SIGTERM)
        try:
            srv.proc.wait(10)
        except subprocess.TimeoutExpired:
            srv.proc.kill()
            srv.proc.wait(5)


def robot_process(
    port: int, name: str, world: str, events: Path, *extra: str
) -> subprocess.Popen[str]:
    """A murdoch-robot process; its stderr goes to EVENTS.log next to the events file."""
    with open(events.with_suffix(".log"), "w", encoding="utf-8") as log:
        return subprocess.Popen(
            [str(BIN / "murdoch-robot"), "-p", str(port), "--name", name, "--world", world,
             "--events", str(events), *extra],
            stdout=subprocess.DEVNULL, stderr=log, text=True,
        )


def read_events(path: Path) -> list[dict[str, object]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


@contextmanager
def observer(port: int) -> Iterator[SimulationProxy]:
    """Ground truth through the simulation device, without holding the lockstep clock."""
    client = PlayerClient(HOST, port, lockstep=False).connect()
    try:
        yield client.subscribe(SimulationProxy, 0)
    finally:
        client.close()


def wait_for(proc: subprocess.Popen[str], timeout_s: float) -> int:
    try:
        return proc.wait(timeout_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        proc.wait(10)
        raise


@pytest.mark.timeout(60)
def test_goto_reaches_a_goal_behind_an_obstacle(tmp_path: Path) -> None:
    # The straight line from robot1 (0, 0) to the goal passes through the pillar at (2, 1.5).
    goal = (3.2, 2.4)
    events = tmp_path / "events.jsonl"
    with server("simple", 1) as srv:
        proc = robot_process(
            srv.ports["robot1"], "robot1", "simple", events, "--task", "goto-goal",
            "--param", f"x={goal[0]}", "--param", f"y={goal[1]}", "--exit-when-done",
            "--no-battery",
        )
        assert wait_for(proc, 45.0) == 0
        with observer(srv.ports["robot1"]) as sim:
            x, y, _ = sim.get_pose2d("robot1")
    kinds = [e["kind"] for e in read_events(events)]
    assert kinds == ["task-start", "task-done"], kinds
    assert math.hypot(x - goal[0], y - goal[1]) < 0.45


@pytest.mark.timeout(60)
def test_free_running_server_and_clean_exit_on_sigterm(tmp_path: Path) -> None:
    events = tmp_path / "events.jsonl"
    with server("simple", 1, lockstep=False, speedup=10.0) as srv:
        proc = robot_process(srv.ports["robot1"], "robot1", "simple", events, "--no-battery",
                             "--task", "goto-goal", "--param", "x=1.5", "--param", "y=-0.2")
        seen = poll_events(events, "task-done", 30.0, proc)
        assert proc.poll() is None  # still in service after its task
        proc.send_signal(signal.SIGTERM)
        assert wait_for(proc, 30.0) == 0
        with observer(srv.ports["robot1"]) as sim:
            x, y, _ = sim.get_pose2d("robot1")
    assert [e["kind"] for e in seen][:2] == ["task-start", "task-done"]
    assert math.hypot(x - 1.5, y + 0.2) < 0.45
    assert '"ready"' in events.with_suffix(".log").read_text()


@pytest.mark.timeout(60)
def test_overhead_camera_monitors_objects_in_world_coordinates(tmp_path: Path) -> None:
    events = tmp_path / "events.jsonl"
    # The overhead camera does not drive, so it never holds a lockstep clock: free-running.
    with server("simple", 1, lockstep=False, speedup=10.0) as srv:
        proc = robot_process(srv.ports["overhead"], "overhead", "simple", events,
                             "--task", "monitor-object", "--param", "colours=red,green",
                             "--param", "duration_s=2", "--param", "period_s=0.5",
                             "--exit-when-done")
        assert wait_for(proc, 40.0) == 0
    seen = read_events(events)
    assert [e["kind"] for e in seen][-1] == "task-done"
    observations = [e for e in seen if e["kind"] == "observation"]
    assert len(observations) >= 3 and all(e["frame"] == "world" for e in observations)
    reds = [o for o in observations[-1]["objects"] if o["colour"] == "#ff0000"]  # type: ignore[union-attr]
    assert reds and math.hypot(reds[0]["x"] - 2.5, reds[0]["y"]) < 0.2, reds


def poll_events(path: Path, until: str, timeout_s: float, proc: subprocess.Popen[str]
                ) -> list[dict[str, object]]:
    """Wait (bounded) until an event of kind `until` has been written."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        events = read_events(path)
        if any(e["kind"] == until for e in events):
            return events
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    raise AssertionError(f"no {until!r} event; saw {[e['kind'] for e in read_events(path)]}")


def stop(proc: subprocess.Popen[str]) -> int:
    proc.send_signal(signal.SIGINT)
    return wait_for(proc, 30.0)


@pytest.mark.timeout(60)
def test_low_battery_robot_docks_charges_and_returns(tmp_path: Path) -> None:
    events = tmp_path / "events.jsonl"
    with server("test_lowbattery", 1) as srv:
        # r1 starts at 40 %: below the threshold, so it goes charging as soon as it is idle.
        proc = robot_process(srv.ports["r1"], "r1", "test_lowbattery", events,
                             "--battery-low", "45", "--battery-resume", "80")
        seen = poll_events(events, "subjects", 40.0, proc)
        with observer(srv.ports["r1"]) as sim:
            x, y, _ = sim.get_pose2d("r1")
        assert stop(proc) == 0
    kinds = [e["kind"] for e in seen]
    assert kinds.index("charge-needed") < kinds.index("charge-start") < kinds.index("charge-end")
    start = next(e for e in seen if e["kind"] == "charge-start")
    end = next(e for e in seen if e["kind"] == "charge-end")
    assert float(start["percent"]) < 45.0 <= 80.0 <= float(end["percent"])  # type: ignore[arg-type]
    assert float(end["time_s"]) > float(start["time_s"])  # type: ignore[arg-type]
    # Docked on the pad at (-2.2, 1.6) (radius 0.45), then backed off it a little.
    assert math.hypot(x + 2.2, y - 1.6) < 1.2


@pytest.mark.timeout(60)
def test_sentry_raises_alarm_when_an_object_is_moved_into_view(tmp_path: Path) -> None:
    events = tmp_path / "events.jsonl"
    with server("simple", 1) as srv:
        # robot1 starts facing the red can 2.5 m ahead.
        proc = robot_process(srv.ports["robot1"], "robot1", "simple", events, "--no-battery",
                             "--task", "sentry-duty", "--param", "colour=red",
                             "--param", "duration_s=600")
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            if any(e["kind"] == "stage" and e.get("stage") == "watch" for e in read_events(events)):
                break
            assert proc.poll() is None
            time.sleep(0.05)
        else:
            raise AssertionError(f"never watching: {read_events(events)}")
        time.sleep(0.5)  # a few quiet seconds of simulated time
        assert not [e for e in read_events(events) if e["kind"] == "alarm"]
        with observer(srv.ports["robot1"]) as sim:
            x, y, yaw = sim.get_pose2d("robot1")
            sim.set_pose2d("box1", x + 1.5 * math.cos(yaw), y + 1.5 * math.sin(yaw), 0.0)
        seen = poll_events(events, "alarm", 20.0, proc)
        assert stop(proc) == 0
    alarm = next(e for e in seen if e["kind"] == "alarm")
    assert alarm["task"] == "sentry-duty" and alarm["signal"] == "motion"


@pytest.mark.timeout(90)
def test_cleanup_pushes_a_small_box_to_the_wall(tmp_path: Path) -> None:
    events = tmp_path / "events.jsonl"
    with server("simple", 1) as srv:
        with observer(srv.ports["robot1"]) as sim:
            bx0, by0, _ = sim.get_pose2d("box1")
        # Seed 1 searches turning right, towards the yellow box ahead on the right.
        proc = robot_process(srv.ports["robot1"], "robot1", "simple", events, "--no-battery",
                             "--task", "cleanup", "--param", "colour=yellow", "--seed", "1",
                             "--param", "duration_s=200", "--exit-when-done")
        assert wait_for(proc, 70.0) == 0
        with observer(srv.ports["robot1"]) as sim:
            bx, by, _ = sim.get_pose2d("box1")
    seen = read_events(events)
    kinds = [e["kind"] for e in seen]
    assert kinds[0] == "task-start" and kinds[-1] == "task-done", kinds
    stages = [e.get("stage") for e in seen if e["kind"] == "stage"]
    assert "push" in stages and "back-off" in stages
    # The arena is 8 x 6 m: the box (0.4 m) ends up against a wall.
    gap = min(4.0 - abs(bx), 3.0 - abs(by))
    assert gap < 0.4, (bx0, by0, bx, by)


class Allocator:
    """A tiny greedy allocator for the test: gives each needed pushing task to the idle
    pusher that scores best on it (the job MURDOCH's auctions do in the full system)."""

    def __init__(self, pushers: dict[str, RobotAgent], params: dict[str, object]) -> None:
        self.pushers = pushers
        self.params = params
        self.needs: tuple[str, ...] = ()
        self.awarded: list[tuple[str, str]] = []
        self._lock = threading.Lock()

    def on_event(self, event: Event) -> None:
        if event.kind == "need":
            with self._lock:
                self.needs = tuple(dict(event.detail)["tasks"])

    def allocate(self) -> None:
        with self._lock:
            needs = self.needs
        busy = {a.status().task for a in self.pushers.values() if a.status().state == "working"}
        for task in needs:
            if task in busy:
                continue
            scores = []
            for name, agent in self.pushers.items():
                if agent.status().state != "idle":
                    continue
                score = agent.evaluate(task, self.params)
                if score is not None:
                    scores.append((score, name))
            if not scores:
                continue
            _, winner = max(scores)
            task_id = f"{task}-{len(self.awarded)}"
            self.pushers[winner].start_task(task, self.params, task_id=task_id)
            self.awarded.append((task, winner))
            busy.add(task)
            # Until the pusher's next tick it still reports idle: one award per round.
            return


@pytest.mark.timeout(150)
def test_two_pushers_and_a_watcher_move_the_box_towards_the_goal() -> None:
    world = load_world(world_path("boxpush"))
    goal = next(m for m in world.markers if m.name == "goal")
    names = ("watcher", "pusher1", "pusher2")
    log = EventLog()
    seen: list[Event] = []
    log.add_sink(seen.append)
    with server("boxpush", len(names)) as srv:
        with observer(srv.ports["watcher"]) as sim:
            bx0, by0, _ = sim.get_pose2d("bigbox")
        clients = [PlayerClient(HOST, srv.ports[n]).connect() for n in names]
        stop_all = threading.Event()
        threads: list[threading.Thread] = []
        try:
            agents = {n: build_agent(c, n, world=world, events=log)
                      for n, c in zip(names, clients, strict=True)}
            pushers = {n: agents[n] for n in names[1:]}
            allocator = Allocator(pushers, {"colour": "orange", "duration_s": 6.0})
            log.add_sink(allocator.on_event)
            agents["watcher"].start_task("watch-box", {"colour": "orange",
                                                      "goal_colour": "magenta"}, "watch")
            threads = [threading.Thread(target=a.run, args=(stop_all,), name=f"agent-{n}")
                       for n, a in agents.items()]
            for t in threads:
                t.start()
            deadline = time.monotonic() + 100.0
            while time.monotonic() < deadline and agents["watcher"].status().time_s < 60.0:
                allocator.allocate()
                time.sleep(0.02)
                assert all(t.is_alive() for t in threads)
        finally:
            stop_all.set()
            for t in threads:
                t.join(20.0)
            for c in clients:
                c.close()
        with observer(srv.ports["watcher"]) as sim:
            bx, by, _ = sim.get_pose2d("bigbox")
    assert not any(t.is_alive() for t in threads)
    assert agents["watcher"].status().time_s >= 60.0
    needs = [e for e in seen if e.kind == "need"]
    assert needs and allocator.awarded
    assert {w for _, w in allocator.awarded} == {"pusher1", "pusher2"}
    before = math.hypot(goal.x - bx0, goal.y - by0)
    after = math.hypot(goal.x - bx, goal.y - by)
    assert after < before - 1.0, (bx0, by0, bx, by, allocator.awarded)
