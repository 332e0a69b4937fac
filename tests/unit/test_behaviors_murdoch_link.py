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
