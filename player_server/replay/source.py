"""A recording read forward in time: the world's robots and, at any moment, the latest
recorded message of each robot's devices.

Messages are read lazily in log-time order (chunk by chunk), so a recording of any length is
served in bounded memory; each message is decoded only when a driver asks for it.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from player_server.record import channels as ch
from player_server.record.reader import Record, RecordingError, iter_messages, read_info, resolve

#: the device channels served back, per Player interface
SERVED = (ch.ODOMETRY, ch.LASER, ch.SONAR_RANGES, ch.BATTERY, ch.BLOBS)


@dataclass
class Latest:
    """The newest message of one channel: its record and, once asked for, its JSON."""

    record: Record
    _decoded: Any = None

    @property
    def message(self) -> Any:
        if self._decoded is None:
            self._decoded = json.loads(self.record.data)
        return self._decoded


class RecordedRun:
    def __init__(self, path: Path) -> None:
        self.path = resolve(Path(path))
        info = read_info(self.path)
        self.start_s = info.start_ns / 1e9
        self.end_s = info.end_ns / 1e9
        self.info = info
        world = next(iter_messages(self.path, topics=[ch.WORLD_INFO]), None)
        if world is None:
            raise RecordingError(f"{self.path}: no {ch.WORLD_INFO} message: not a run recording")
        try:
            meta = world.json()
            self.world = str(meta["world"])
            self.interval_s = float(meta["interval_s"])
            self.robots: dict[str, Any] = dict(meta["robots"])
        except (ValueError, KeyError, TypeError) as exc:
            raise RecordingError(f"{self.path}: unreadable {ch.WORLD_INFO}: {exc}") from exc
        if not self.interval_s > 0:
            raise RecordingError(f"{self.path}: tick interval {self.interval_s} is not positive")
        self.topics = {ch.robot_topic(r, c): (r, c) for r in self.robots for c in SERVED}
        self._messages: Iterator[Record] = iter_messages(self.path, topics=list(self.topics))
        self._next: Record | None = next(self._messages, None)
        self._latest: dict[tuple[str, str], Latest] = {}
        self.read = 0

    def recorded(self, robot: str) -> set[str]:
        """The channels recorded for a robot (those with at least one message)."""
        topics = self.info.channels
        return {c for c in SERVED if ch.robot_topic(robot, c) in topics
                and topics[ch.robot_topic(robot, c)].messages > 0}

    def advance_to(self, t_s: float) -> None:
        """Take in every message recorded at or before `t_s`."""
        limit = ch.nanoseconds(t_s)
        nxt = self._next
        while nxt is not None and nxt.log_time_ns <= limit:
            key = self.topics.get(nxt.topic)
            if key is not None:
                self._latest[key] = Latest(nxt)
            self.read += 1
            nxt = next(self._messages, None)
        self._next = nxt

    def latest(self, robot: str, channel: str) -> Latest | None:
        return self._latest.get((robot, channel))


class ReplayClock:
    """The `Steppable` of a replay: each step moves recorded time on by one tick."""

    def __init__(self, run: RecordedRun) -> None:
        self.run = run
        self.tick = 0
        self.interval_s = run.interval_s
        run.advance_to(self.time_s)

    @property
    def time_s(self) -> float:
        return self.run.start_s + self.tick * self.interval_s

    @property
    def paused(self) -> bool:
        return False

    def step(self, n: int = 1) -> None:
        self.tick += n
        self.run.advance_to(self.time_s)
