"""Observing a simulation at bounded rates; following robot event files."""

from __future__ import annotations

import json
from pathlib import Path

from experiments.observe import JsonlTail, ObservedSim, robot_event_to_run_events
from player_server.viz.feed import LiveFeed


class CountingSim:
    """Pure stand-in with the Steppable + snapshot shape (counts snapshot calls)."""

    def __init__(self) -> None:
        self.tick = 0
        self.snapshots = 0

    @property
    def time_s(self) -> float:
        return self.tick * 0.1

    @property
    def paused(self) -> bool:
        return False

    def step(self, n: int = 1) -> None:
        self.tick += n

    def snapshot(self) -> object:
        self.snapshots += 1

        class Snap:
            bodies = (("p1", "robot", self.tick * 0.01, 0.0, 0.0),)

        return Snap()

    def robot_names(self) -> tuple[str, ...]:
        return ("p1",)


class RecordingView:
    """Pure stand-in for the live view: keeps what it is handed."""

    def __init__(self) -> None:
        self.offered: list[object] = []
        self.battery: dict[str, float] = {}
        self.states: dict[str, str] = {}
        self.scans: list[dict] = []

    def offer(self, snapshot: object) -> None:
        self.offered.append(snapshot)

    def offer_scans(self, scans: dict) -> None:
        self.scans.append(dict(scans))

    def set_battery(self, robot: str, percent: float) -> None:
        self.battery[robot] = percent

    def set_robot(self, robot: str, state: str, label: str = "") -> None:
        self.states[robot] = state


class PoweredSim(CountingSim):
    class Power:
        percent = 42.5
        charging = True

    def power(self, robot: str) -> Power:
        return self.Power()

    def laser(self, robot: str) -> object:
        import numpy as np

        return np.array([1.0, 2.0])


def test_samplers_on_simulated_time_live_feed_on_wall_time() -> None:
    sim = PoweredSim()
    wall = [0.0]
    view = RecordingView()
    sampled: list[float] = []
    feed = LiveFeed(view, wall_clock=lambda: wall[0], period_s=0.1, power_robots=("p1",))
    obs = ObservedSim(sim, live=feed.after_step,
                      samplers=((1.0, lambda s, t: sampled.append(round(t, 3))),))
    for _ in range(600):  # 60 simulated seconds in 0.6 wall seconds
        obs.step()
        wall[0] += 0.001
    assert len(sampled) == 60 and sampled[:2] == [0.1, 1.1]  # one per simulated second
    assert 6 <= len(view.offered) <= 7  # one per 0.1 wall second
    assert sim.snapshots == len(view.offered) == feed.frames
    assert view.battery == {"p1": 42.5}
    assert view.states == {} and view.scans == []  # states come from the team's events
    assert obs.robot_names() == ("p1",)  # the rest of the simulation shows through


def test_feed_of_a_world_without_a_team_shows_charging_and_lasers() -> None:
    sim = PoweredSim()
    view = RecordingView()
    feed = LiveFeed(view, wall_clock=lambda: 0.0, power_robots=("p1",), scan_robots=("p1",),
                    states_from_power=True)
    feed.after_step(sim)
    feed.after_step(sim)  # same wall time: nothing more
    assert view.states == {"p1": "charging"} and view.scans == [{"p1": [1.0, 2.0]}]
    assert len(view.offered) == 1


def test_no_observers_no_snapshots() -> None:
    sim = CountingSim()
    obs = ObservedSim(sim)
    for _ in range(100):
        obs.step()
    assert sim.snapshots == 0 and obs.time_s == sim.time_s


def test_tail_follows_appends_and_partial_lines(tmp_path: Path) -> None:
    path = tmp_path / "r1.jsonl"
    tail = JsonlTail(path)
    assert list(tail.read_new()) == []  # no file yet
    path.write_text('{"a": 1}\n{"b": ')
    assert list(tail.read_new()) == [{"a": 1}]
    with path.open("a") as f:
        f.write('2}\nnot json\n[1]\n')
    assert list(tail.read_new()) == [{"b": 2}]
    assert tail.malformed == 2


def test_robot_events_translate() -> None:
    base = {"time_s": 12.0, "robot": "p2", "task": "", "task_id": ""}
    (e,) = robot_event_to_run_events({**base, "kind": "charge-start", "percent": 24.0})
    assert e == {"t": 12.0, "kind": "charge_start", "robot": "p2", "percent": 24.0}
    (e,) = robot_event_to_run_events(
        {**base, "kind": "task-done", "task": "cleanup", "task_id": "t4"})
    assert (e["kind"], e["phase"], e["task"], e["task_kind"]) == ("robot_task", "done", "t4",
                                                                   "cleanup")
    assert robot_event_to_run_events({**base, "kind": "observation"}) == []
    assert robot_event_to_run_events({"kind": "charge-start"}) == []
    assert json.dumps(robot_event_to_run_events({**base, "kind": "alarm"}))
