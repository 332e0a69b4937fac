"""Watching a running simulation without slowing it down.

`ObservedSim` wraps a `player_server.sim.Simulation` for `PlayerServer` (it is a `Steppable`):
after each step, on the serving thread that owns the PyBullet client, it runs its samplers
(each every so many simulated seconds: the run recording, battery events, the boxpush referee)
and then the live view's feed, if any (which keeps to its own wall-clock rate).

`JsonlTail` follows a JSON-lines file another process appends to (robot event logs).
`robot_event_to_run_events` turns a robot's event into run events.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, Protocol

from experiments import events as ev

log = logging.getLogger(__name__)

Pose = tuple[float, float, float]


class SnapshotSim(Protocol):
    @property
    def time_s(self) -> float: ...

    @property
    def paused(self) -> bool: ...

    def step(self, n: int = 1) -> object: ...

    def snapshot(self) -> Any: ...


def snapshot_poses(snapshot: Any) -> dict[str, Pose]:
    """(x, y, yaw) by body name from a `SceneSnapshot` (bodies of (name, kind, x, y, yaw))."""
    out: dict[str, Pose] = {}
    for body in snapshot.bodies:
        if isinstance(body, tuple):
            name, _kind, x, y, yaw = body[:5]
        else:
            name, x, y, yaw = body.name, body.x, body.y, body.yaw
        out[str(name)] = (float(x), float(y), float(yaw))
    return out


class ObservedSim:
    def __init__(
        self,
        sim: SnapshotSim,
        *,
        samplers: tuple[tuple[float, Callable[[Any, float], None]], ...] = (),
        live: Callable[[Any], None] | None = None,
    ) -> None:
        """`live(sim)` runs after every step: the live view's feed, which keeps to its own
        wall-clock rate (`player_server.viz.feed.LiveFeed.after_step`)."""
        self.sim = sim
        # (period in simulation seconds, callback(sim, t)) run on the serving thread
        self._samplers = [(period, fn, [-1.0]) for period, fn in samplers]
        self._live = live

    @property
    def time_s(self) -> float:
        return self.sim.time_s

    @property
    def paused(self) -> bool:
        return self.sim.paused

    def __getattr__(self, name: str) -> Any:
        # everything else (robot_names, power, ...) is the simulation's own
        return getattr(self.sim, name)

    def step(self, n: int = 1) -> None:
        self.sim.step(n)
        t = self.sim.time_s
        for period, fn, due in self._samplers:
            if t >= due[0]:
                due[0] = t + period
                fn(self.sim, t)
        if self._live is not None:
            self._live(self.sim)


class JsonlTail:
    """Yields the complete new lines of a growing JSON-lines file, parsed; bad lines are
    skipped and counted. Reads at most `max_bytes` per call, so one call is bounded."""

    def __init__(self, path: Path, *, max_bytes: int = 1 << 20) -> None:
        self.path = Path(path)
        self._offset = 0
        self._partial = b""
        self._max = max_bytes
        self.malformed = 0
        self._fd: int | None = None

    def read_new(self) -> Iterator[dict[str, Any]]:
        """The lines completed since the last call (one read while nothing is new: the file
        stays open between calls, which can come every simulation tick)."""
        fd = self._fd
        if fd is None:
            try:
                fd = self._fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
            except FileNotFoundError:
                return
        chunk = os.pread(fd, self._max, self._offset)
        if not chunk:
            return
        self._offset += len(chunk)
        data = self._partial + chunk
        *lines, self._partial = data.split(b"\n")
        for line in lines:
            if not line.strip():
                continue
            try:
                obj = json.loads(line)
            except ValueError:
                self.malformed += 1
                continue
            if isinstance(obj, dict):
                yield obj
            else:
                self.malformed += 1

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


_ROBOT_KINDS = {
    "charge-start": ev.CHARGE_START,
    "charge-end": ev.CHARGE_END,
    "alarm": ev.ALARM,
}


def robot_event_to_run_events(d: Mapping[str, Any]) -> list[dict[str, Any]]:
    """A `behaviors.events.Event` dict (time_s, robot, kind, task, task_id, ...) as run events.

    Charging and alarms map to their run kinds; task start/finish/fail as seen by the robot are
    kept as ``robot_task`` (the terminal outcome of a task is the auctioneer's to report).
    Anything unusable gives no event.
    """
    try:
        t = float(d["time_s"])
        robot = str(d["robot"])
        kind = str(d["kind"])
    except (KeyError, TypeError, ValueError):
        return []
    extra = {k: v for k, v in d.items() if k not in ("time_s", "robot", "kind", "task", "task_id")}
    try:
        if kind in _ROBOT_KINDS:
            return [ev.make_event(t, _ROBOT_KINDS[kind], robot=robot, **extra)]
        if kind.startswith("task-"):
            return [ev.make_event(t, "robot_task", robot=robot, phase=kind[5:],
                                  task=str(d.get("task_id") or ""),
                                  task_kind=str(d.get("task") or ""), **extra)]
    except ev.EventError:
        return []
    return []
