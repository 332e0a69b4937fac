"""Events a robot reports (task start/finish/fail, alarms, charging), stamped with sim time."""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import IO, Any

logger = logging.getLogger(__name__)

TASK_START = "task-start"
TASK_DONE = "task-done"
TASK_FAILED = "task-failed"
TASK_STOPPED = "task-stopped"
STAGE = "stage"
ALARM = "alarm"
NEED = "need"
OBSERVATION = "observation"
CHARGE_NEEDED = "charge-needed"
CHARGE_START = "charge-start"
CHARGE_END = "charge-end"
SUBJECTS = "subjects"


@dataclass(frozen=True, slots=True)
class Event:
    time_s: float
    robot: str
    kind: str
    task: str = ""
    task_id: str = ""
    detail: tuple[tuple[str, Any], ...] = ()

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "time_s": self.time_s,
            "robot": self.robot,
            "kind": self.kind,
            "task": self.task,
            "task_id": self.task_id,
        }
        out.update(self.detail)
        return out


def detail(values: Mapping[str, Any]) -> tuple[tuple[str, Any], ...]:
    return tuple(sorted(values.items()))


EventSink = Callable[[Event], None]


class EventLog:
    """Fans events out to sinks, logs them, and optionally appends JSON lines to a stream.

    Sinks are called on the thread that emits (the robot's control loop); they must be quick.
    """

    def __init__(self, stream: IO[str] | None = None) -> None:
        self._lock = threading.Lock()
        self._sinks: list[EventSink] = []
        self._stream = stream
        self._count = 0

    def add_sink(self, sink: EventSink) -> None:
        with self._lock:
            self._sinks.append(sink)

    @property
    def count(self) -> int:
        return self._count

    def emit(self, event: Event) -> None:
        logger.info(
            "t=%.2f %s %s %s %s", event.time_s, event.robot, event.kind, event.task,
            dict(event.detail) if event.detail else "",
        )
        with self._lock:
            self._count += 1
            sinks = tuple(self._sinks)
            if self._stream is not None:
                self._stream.write(json.dumps(event.as_dict(), default=str) + "\n")
                self._stream.flush()
        for sink in sinks:
            sink(event)
