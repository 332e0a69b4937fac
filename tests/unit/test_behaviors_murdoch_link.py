"""The robot's MURDOCH glue: how a robot scores announcements."""

from __future__ import annotations

import logging
import random
from dataclasses import dataclass
from typing import Any

import pytest

from behaviors.events import EventLog
from behaviors.murdoch_link import MurdochLink
from behaviors.params import ParamError
from murdoch.auction.messages import Announce
from murdoch.memory_bus import MemoryBus


@dataclass
class _Status:
    time_s: float = 1.0


class _Agent:
    """Just what the link asks of a robot agent."""

    name = "r1"

    def __init__(self, evaluate: Any) -> None:
        self.evaluate = evaluate
        self.ticks = 0

    def subjects(self) -> frozenset[str]:
        return frozenset({"mobile", "camera"})

    def status(self) -> _Status:
        return _Status()


def _link(evaluate: Any) -> MurdochLink:
    bus = MemoryBus(lambda: 1.0, random.Random(1))
    return MurdochLink(_Agent(evaluate), bus.endpoint("r1"), EventLog(None))


def _announce(name: str = "object-tracking") -> Announce:
    return Announce("t1", 1, name, ("camera", "mobile"), {"colour": "red"}, 60.0, (),
                    "task.t1", 1.0, 2.0, 10.0, None)


def test_a_metric_that_raises_is_a_logged_and_counted_bug_not_a_quiet_no(
    caplog: pytest.LogCaptureFixture,
) -> None:
    def broken(task: str, params: Any) -> float:
        raise ZeroDivisionError("a bug in the metric")

    link = _link(broken)
    with caplog.at_level(logging.ERROR):
        assert link._metric(_announce()) is None
    assert link.metric_errors == 1
    (record,) = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert "object-tracking" in record.getMessage() and record.exc_info is not None


def test_unknown_tasks_and_refused_parameters_are_a_plain_no() -> None:
    def refuses(task: str, params: Any) -> float:
        raise ParamError("no such colour")

    link = _link(refuses)
    assert link._metric(_announce("no-such-task")) is None
    assert link._metric(_announce()) is None
    assert link.metric_errors == 0
    assert _link(lambda task, params: 0.7)._metric(_announce()) == 0.7


class _RefusingAgent(_Agent):
    """A robot whose library refuses the task's parameters when it is started."""

    def __init__(self, clock: Any) -> None:
        super().__init__(lambda task, params: 1.0)
        self.clock = clock

    def status(self) -> _Status:
        return _Status(self.clock())

    def start_task(self, task: str, params: Any, task_id: str = "") -> None:
        raise ParamError(f"{task}: no such colour")

    def stop_task(self, reason: str = "stopped") -> None:
        pass

    def step(self) -> None:
        self.ticks += 1


@pytest.mark.parametrize("allocator", ["cbba", "cbga"])
def test_a_consensus_robot_fails_a_task_it_cannot_start_and_keeps_running(
        allocator: str) -> None:
    from murdoch.allocators import ALLOCATORS, UserHooks
    from murdoch.auction.timing import USER_TASK
    from murdoch.user_agent import RandomizedBackoff

    now = [0.0]
    bus = MemoryBus(lambda: now[0], random.Random(1))
    team = ALLOCATORS[allocator]
    events: list[Any] = []
    user = team.user(bus.endpoint("user", team.codec), lambda: now[0],
                     UserHooks("user", events.append, RandomizedBackoff(random.Random(1))))
    link = MurdochLink(_RefusingAgent(lambda: now[0]), bus.endpoint("r1", team.codec),
                       EventLog(None), allocator_name=allocator, team=("r1",))
    task = user.announce(USER_TASK.task("object-tracking", {"camera", "mobile"},
                                        {"colour": "mauve", "duration_s": 5.0},
                                        duration_s=5.0, timeout_s=60.0), patience_s=30.0)
    for _ in range(100):
        now[0] = round(now[0] + 0.1, 6)
        link.step()
        user.step()
    outcomes = [(e.task_id, e.detail.get("status"), e.detail.get("reason")) for e in events
                if e.kind == "outcome"]
    assert outcomes == [(task, "failed", "bad parameters: object-tracking: no such colour")]
