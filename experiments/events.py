"""The run's event log: one JSON object per line in ``events.jsonl``.

Every line has ``t`` (simulation seconds, float) and ``kind`` (str), plus the fields of its
kind listed in `REQUIRED_FIELDS` (more fields are allowed and kept). docs/experiments.md is
the reference for the schema; this module is its single definition in code.

Writers append and flush at least every `flush_every` lines or `flush_period_s` seconds of the
injected clock, so a long run never holds more than a buffer's worth of events in memory and a
crash loses at most that much. Readers skip (and count) malformed lines, such as a last line
cut short by a crash.
"""

from __future__ import annotations

import json
import logging
import math
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

log = logging.getLogger(__name__)

# --- kinds ---
RUN_START = "run_start"
RUN_END = "run_end"
TASK_INTRODUCED = "task_introduced"
MESSAGE = "message"
AWARD = "award"
REALLOCATION = "reallocation"
TASK_OUTCOME = "task_outcome"
CHARGE_START = "charge_start"
CHARGE_END = "charge_end"
ROBOT_FAILURE = "robot_failure"
ROBOT_RESTART = "robot_restart"
BATTERY = "battery"
PROCESS = "process"
BID_DECLINED = "bid_declined"
"""A robot refused an award (it was busy, or its bid had expired)."""
BID_EXPIRED = "bid_expired"
"""A robot stopped waiting for the award of a round it bid in (no award within the bound)."""
PROCESS_NOTE = "process_note"
"""(processes.jsonl) a robot process started, was killed or exited, with its pid."""
FAULT_SKIPPED = "fault_skipped"
"""A fault of the schedule that found nothing to act on (e.g. kill busy with nobody busy)."""
RUN_WALL = "run_wall"
"""(processes.jsonl) the run's wall time when it ended."""
ALARM = "alarm"
POSES = "poses"
GOAL_REACHED = "goal_reached"
GOAL_UNACHIEVABLE = "goal_unachievable"
ROBOT_SWITCH_OFF = "robot_switch_off"
ROBOT_SWITCH_ON = "robot_switch_on"
NO_BID = "no_bid"
"""An auction round of a task closed without a bid (attempt 1: the task's first auction)."""
BOX_PROGRESS = "box_progress"
"""boxpush: the box's ground-truth distance to the goal, once per simulated second."""
GOAL_MOVED = "goal_moved"
"""boxpush: the goal marker moved (a moving goal, or a new goal for the watch task)."""
BOX_ROUND = "box_round"
"""boxpush: the box reached the goal and a new round began (the box and the robots back at
their start, the watch task introduced again)."""
ROBOT_FREEZE = "robot_freeze"
"""(soak) a robot's process was stopped; it no longer holds the lockstep clock."""
ROBOT_THAW = "robot_thaw"
"""(soak) the stopped process continued."""
CHARGER_OFF = "charger_off"
"""(soak) a charging pad stopped charging."""
CHARGER_ON = "charger_on"
"""(soak) it charges again."""
TASK_BURST = "task_burst"
"""(soak) many tasks introduced at one tick (after their own task_introduced events)."""

COMPLETED = "completed"
FAILED = "failed"
UNACHIEVABLE = "unachievable"
OUTCOMES: tuple[str, ...] = (COMPLETED, FAILED, UNACHIEVABLE)
# a task still open when the run stopped: neither done nor failed by anyone. Written as this
# outcome, or (older runs) as ``failed`` with a reason starting "run ended"
OPEN_AT_END = "open_at_end"
RUN_ENDED_REASON = "run ended"
COUNTED_OUTCOMES: tuple[str, ...] = (*OUTCOMES, OPEN_AT_END)


def counted_outcome(event: Mapping[str, Any]) -> str:
    """The outcome a task_outcome event counts as: ``open_at_end`` for a task the run's end
    cut short, else the outcome written."""
    outcome = str(event.get("outcome", ""))
    if outcome == FAILED and str(event.get("reason", "")).startswith(RUN_ENDED_REASON):
        return OPEN_AT_END
    return outcome

REQUIRED_FIELDS: dict[str, tuple[str, ...]] = {
    RUN_START: ("experiment", "seed"),
    RUN_END: ("reason",),
    TASK_INTRODUCED: ("task", "task_kind"),
    MESSAGE: ("msg_kind", "sender", "bytes"),
    AWARD: ("task", "robot"),
    REALLOCATION: ("task", "from_robot", "reason"),
    TASK_OUTCOME: ("task", "outcome"),
    CHARGE_START: ("robot",),
    CHARGE_END: ("robot",),
    ROBOT_FAILURE: ("robot",),
    ROBOT_RESTART: ("robot",),
    BATTERY: ("percent",),
    PROCESS: ("name", "pid", "rss_bytes"),
    ALARM: ("robot",),
    POSES: ("bodies",),
    GOAL_REACHED: ("box", "distance_m"),
    GOAL_UNACHIEVABLE: ("task", "reason"),
    ROBOT_SWITCH_OFF: ("robot",),
    ROBOT_SWITCH_ON: ("robot", "x", "y"),
    NO_BID: ("task", "attempt"),
    BOX_PROGRESS: ("distance_m",),
    GOAL_MOVED: ("x", "y"),
    BOX_ROUND: ("round", "task"),
    ROBOT_FREEZE: ("robot",),
    ROBOT_THAW: ("robot",),
    CHARGER_OFF: ("charger",),
    CHARGER_ON: ("charger",),
    TASK_BURST: ("count",),
}


class EventError(ValueError):
    """An event that does not follow the schema."""


def make_event(t: float, kind: str, **fields: Any) -> dict[str, Any]:
    """Build and check one event; raises `EventError` with what is wrong."""
    if not isinstance(t, int | float) or isinstance(t, bool) or not math.isfinite(t):
        raise EventError(f"event {kind!r}: t must be a finite number of seconds, got {t!r}")
    if not isinstance(kind, str) or not kind:
        raise EventError(f"event kind must be a non-empty string, got {kind!r}")
    if "t" in fields or "kind" in fields:
        raise EventError(f"event {kind!r}: fields may not be named 't' or 'kind'")
    missing = [f for f in REQUIRED_FIELDS.get(kind, ()) if f not in fields]
    if missing:
        raise EventError(f"event {kind!r} lacks field(s) {', '.join(missing)}")
    if kind == TASK_OUTCOME and fields["outcome"] not in COUNTED_OUTCOMES:
        raise EventError(
            f"event {kind!r}: outcome must be one of {COUNTED_OUTCOMES}, "
            f"got {fields['outcome']!r}"
        )
    return {"t": float(t), "kind": kind, **fields}


def encode_event(event: Mapping[str, Any]) -> str:
    return json.dumps(event, separators=(",", ":"), allow_nan=False, default=_json_default)


def _json_default(value: Any) -> Any:
    # numpy scalars and arrays, tuples of them, Paths
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot write {type(value).__name__} into an event")


class EventWriter:
    """Appends events to a JSON-lines file. Thread-safe; close it (or use `with`)."""

    def __init__(
        self,
        path: Path,
        *,
        clock: Callable[[], float],
        flush_every: int = 200,
        flush_period_s: float = 1.0,
    ) -> None:
        if flush_every < 1:
            raise ValueError("flush_every must be at least 1")
        self.path = Path(path)
        self._clock = clock
        self._flush_every = flush_every
        self._flush_period_s = flush_period_s
        self._lock = threading.Lock()
        self._file: TextIO | None = self.path.open("a", encoding="utf-8", buffering=1 << 16)
        self._unflushed = 0
        self._last_flush = clock()
        self.written = 0

    def write(self, t: float, kind: str, **fields: Any) -> dict[str, Any]:
        event = make_event(t, kind, **fields)
        self.write_event(event)
        return event

    def write_event(self, event: Mapping[str, Any]) -> None:
        line = encode_event(event) + "\n"
        with self._lock:
            if self._file is None:
                raise ValueError(f"event log {self.path} is closed")
            self._file.write(line)
            self.written += 1
            self._unflushed += 1
            now = self._clock()
            if (
                self._unflushed >= self._flush_every
                or now - self._last_flush >= self._flush_period_s
            ):
                self._file.flush()
                self._unflushed = 0
                self._last_flush = now

    def flush(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.flush()
                self._unflushed = 0
                self._last_flush = self._clock()

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None

    def __enter__(self) -> EventWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(slots=True)
class ReadStats:
    lines: int = 0
    events: int = 0
    malformed: int = 0


def iter_events(
    path: Path, *, stats: ReadStats | None = None, kinds: Iterable[str] | None = None
) -> Iterator[dict[str, Any]]:
    """Events of a JSON-lines file in file order; malformed lines are skipped and counted."""
    wanted = set(kinds) if kinds is not None else None
    st = stats if stats is not None else ReadStats()
    with Path(path).open("r", encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            st.lines += 1
            if not line.strip():
                continue
            try:
                obj = json.loads(line)
                if not isinstance(obj, dict):
                    raise EventError("not a JSON object")
                make_event(obj.get("t"), obj.get("kind"),  # type: ignore[arg-type]
                           **{k: v for k, v in obj.items() if k not in ("t", "kind")})
            except (ValueError, TypeError) as exc:
                st.malformed += 1
                log.warning("%s:%d: skipped malformed event: %s", path, lineno, exc)
                continue
            st.events += 1
            if wanted is None or obj["kind"] in wanted:
                yield obj


def read_events(path: Path, *, stats: ReadStats | None = None) -> list[dict[str, Any]]:
    return list(iter_events(path, stats=stats))
