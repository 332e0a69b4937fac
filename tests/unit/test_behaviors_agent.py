"""The robot agent's control loop and API over a small kinematic robot (no server)."""

from __future__ import annotations

import dataclasses
import math
import threading

import pytest

from behaviors.agent import RobotAgent
from behaviors.battery import BatteryPolicy
from behaviors.events import Event, EventLog
from behaviors.params import ParamError
from behaviors.profile import Charger, RobotProfile
from behaviors.proposal import Proposal
from behaviors.snapshot import Mark, Odometry, Pose2D, Power, RangeScan, Snapshot

SONAR_BEARINGS = tuple(math.radians(a) for a in (90, 50, 30, 10, -10, -30, -50, -90))


class KinematicIO:
    """A unicycle robot in an empty room with a battery and one charging pad (dt = 0.1 s)."""

    def __init__(self, percent: float = 100.0, drain_per_s: float = 0.5) -> None:
        self.t = 0.0
        self.x = self.y = self.yaw = 0.0
        self.v = self.w = 0.0
        self.percent = percent
        self.drain = drain_per_s
        self.commands = 0
        self.closed = False

    def read(self, mark: Mark | None) -> Snapshot:
        dt = 0.1
        self.t = round(self.t + dt, 6)
        self.yaw += self.w * dt
        self.x += self.v * math.cos(self.yaw) * dt
        self.y += self.v * math.sin(self.yaw) * dt
        on_pad = math.hypot(self.x - 2.0, self.y - 1.0) < 0.3
        self.percent = min(100.0, self.percent + 5.0 * dt) if on_pad else max(
            0.0, self.percent - self.drain * dt
        )
        return Snapshot(
            self.t,
            odometry=Odometry(Pose2D(self.x, self.y, self.yaw), self.v, self.w, False, self.t),
            sonar=RangeScan((5.0,) * 8, SONAR_BEARINGS, 5.0, self.t),
            power=Power(self.percent, 12.0, 1 if on_pad else 0, self.t),
            mark=mark,
        )

    def command(self, vx_mps: float, vyaw_radps: float) -> None:
        self.v, self.w = vx_mps, vyaw_radps
        self.commands += 1

    def close(self) -> None:
        self.closed = True


PROFILE = RobotProfile("r1", frozenset({"mobile", "sonar", "power"}),
                       chargers=(Charger("pad", 2.0, 1.0, 0.3),))


def make(io: KinematicIO, battery: BatteryPolicy | None = None) -> tuple[RobotAgent, list[Event]]:
    seen: list[Event] = []
    log = EventLog()
    log.add_sink(seen.append)
    return RobotAgent(io, PROFILE, events=log, battery=battery), seen


def kinds(events: list[Event]) -> list[str]:
    return [e.kind for e in events]


def test_goto_runs_to_completion_with_events_and_status() -> None:
    io = KinematicIO()
    agent, seen = make(io)
    agent.step()
    assert agent.status().state == "idle"
    near = agent.evaluate("goto-goal", {"x": 1.0, "y": 1.0})
    far = agent.evaluate("goto-goal", {"x": 4.0, "y": 4.0})
    assert near is not None and far is not None and near > far
    assert agent.evaluate("cleanup", {"colour": "red"}) is None  # no camera or bumper
    agent.start_task("goto-goal", {"x": 1.5, "y": 1.0}, task_id="t-1")
    progress = []
    for _ in range(300):
        agent.step()
        progress.append(agent.status().progress)
        if agent.status().state == "idle" and agent.ticks > 2:
            break
    assert kinds(seen) == ["task-start", "task-done"]
    assert seen[1].task == "goto-goal" and seen[1].task_id == "t-1"
    assert math.hypot(io.x - 1.5, io.y - 1.0) < 0.35
    assert max(progress) > 0.5
    assert seen[1].time_s > seen[0].time_s > 0.0


def test_stop_and_replace_and_bad_parameters() -> None:
    io = KinematicIO()
    agent, seen = make(io)
    with pytest.raises(ParamError):
        agent.start_task("goto-goal", {"x": 1.0})
    with pytest.raises(ParamError):
        agent.start_task("teleport", {})
    agent.start_task("goto-goal", {"x": 5.0, "y": 0.0}, "a")
    agent.step()
    agent.start_task("goto-goal", {"x": -5.0, "y": 0.0}, "b")
    agent.step()
    assert agent.status().task_id == "b"
    agent.stop_task("operator")
    agent.step()
    assert kinds(seen) == ["task-start", "task-stopped", "task-start", "task-stopped"]
    assert agent.status().state == "idle" and io.v == 0.0


def test_low_battery_when_idle_goes_charging_and_returns() -> None:
    io = KinematicIO(percent=21.0, drain_per_s=0.5)
    agent, seen = make(io, BatteryPolicy(low_percent=20.0, resume_percent=60.0))
    states = set()
    subjects_while_charging = set()
    for _ in range(1500):
        agent.step()
        states.add(agent.status().state)
        if agent.status().state == "charging":
            subjects_while_charging |= agent.subjects()
        if "subjects" in kinds(seen):
            break
    k = kinds(seen)
    assert k.index("charge-needed") < k.index("charge-start") < k.index("charge-end")
    assert states >= {"idle", "charging"} and not subjects_while_charging
    assert agent.status().state == "idle" and agent.subjects() == PROFILE.subjects
    start = next(e for e in seen if e.kind == "charge-start")
    end = next(e for e in seen if e.kind == "charge-end")
    assert dict(end.detail)["percent"] >= 60.0 > dict(start.detail)["percent"]
    # A task offered while charging is refused with an event.
    agent2, seen2 = make(KinematicIO(percent=10.0), BatteryPolicy(20.0, 90.0))
    agent2.step()
    agent2.start_task("goto-goal", {"x": 1, "y": 1}, "x")
    agent2.step()
    assert ("task-failed", "goto-goal") in [(e.kind, e.task) for e in seen2]


@dataclasses.dataclass(frozen=True)
class Exploding:
    name: str = "exploding"
    max_speed_mps: float = 0.1
    max_turn_radps: float = 0.1

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        raise ZeroDivisionError("boom")


def test_behaviour_exception_fails_the_task_and_the_robot_carries_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import behaviors.library as library
    from behaviors.arbiter import Layer
    from behaviors.task import Stage, TaskPlan

    spec = library.TASKS["goto-goal"]
    broken = dataclasses.replace(
        spec, build_plan=lambda p, prof: TaskPlan("goto-goal", (Stage("s", (Layer(Exploding()),)),))
    )
    monkeypatch.setitem(library.TASKS, "goto-goal", broken)
    io = KinematicIO()
    agent, seen = make(io)
    agent.start_task("goto-goal", {"x": 1, "y": 1})
    agent.step()
    agent.step()
    assert kinds(seen) == ["task-start", "task-failed"]
    assert "boom" in dict(seen[1].detail)["reason"]
    assert agent.status().state == "idle"


def test_run_stops_when_asked_and_joins_threads() -> None:
    io = KinematicIO()
    agent, _ = make(io)
    agent.start_task("goto-goal", {"x": 3.0, "y": 0.0})
    stop = threading.Event()
    before = threading.active_count()
    agent.run(stop, max_ticks=20)
    assert agent.ticks == 20 and io.v == 0.0 and io.closed
    assert threading.active_count() <= before
    stop.set()
    agent2, _ = make(KinematicIO())
    agent2.run(stop)
    assert agent2.ticks == 0
