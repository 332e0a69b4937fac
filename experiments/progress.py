"""Progress while an experiment runs.

`ProgressTracker` folds events into the figures shown (pure). `ProgressDisplay` shows them: on
a terminal a rich progress bar of simulated time with its ETA (the run's length is known) above
a live table, redrawn a few times a second; otherwise a first plain line within a second of the
start, then one every `line_period_sim_s` of simulation time (default five simulated minutes)
plus a final line.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, TextIO

from rich.console import Console, Group, RenderableType
from rich.live import Live
from rich.progress_bar import ProgressBar
from rich.table import Table
from rich.text import Text

from experiments import events as ev
from experiments import timeline


@dataclass(frozen=True, slots=True)
class Progress:
    sim_s: float
    wall_s: float
    introduced: int
    allocated: int
    completed: int
    failed: int
    unachievable: int
    reallocations: int
    open_at_end: int
    charging: int
    failed_robots: int
    lowest_battery_percent: float | None

    @property
    def real_time_factor(self) -> float | None:
        return self.sim_s / self.wall_s if self.wall_s > 0 else None


def hms(seconds: float) -> str:
    s = int(max(0.0, seconds))
    return f"{s // 3600}:{(s % 3600) // 60:02d}:{s % 60:02d}"


class ProgressTracker:
    """Folds events into `Progress` figures. Thread-safe."""

    def __init__(self, robots: tuple[str, ...] = ()) -> None:
        self._lock = threading.Lock()
        self._states = timeline.RobotStateTracker()
        for r in robots:
            self._states.add_robot(r)
        self._sim_s = 0.0
        self._introduced = 0
        self._allocated: set[str] = set()
        self._outcomes = {o: 0 for o in ev.COUNTED_OUTCOMES}
        self._reallocations = 0
        self._battery: dict[str, float] = {}

    def apply(self, event: Mapping[str, Any]) -> None:
        kind = event["kind"]
        with self._lock:
            self._sim_s = max(self._sim_s, float(event["t"]))
            if kind == ev.TASK_INTRODUCED:
                self._introduced += 1
            elif kind == ev.AWARD:
                self._allocated.add(str(event["task"]))
            elif kind == ev.TASK_OUTCOME and ev.counted_outcome(event) in self._outcomes:
                self._outcomes[ev.counted_outcome(event)] += 1
            elif kind == ev.REALLOCATION:
                self._reallocations += 1
            elif kind == ev.BATTERY:
                self._battery.update({str(k): float(v) for k, v in event["percent"].items()})
            self._states.apply(event)

    def advance(self, sim_s: float) -> None:
        """Simulation time moved on without an event."""
        with self._lock:
            self._sim_s = max(self._sim_s, sim_s)

    def progress(self, wall_s: float) -> Progress:
        with self._lock:
            states = [s.state for s in self._states.states().values()]
            return Progress(
                sim_s=self._sim_s,
                wall_s=wall_s,
                introduced=self._introduced,
                allocated=len(self._allocated),
                completed=self._outcomes[ev.COMPLETED],
                failed=self._outcomes[ev.FAILED],
                unachievable=self._outcomes[ev.UNACHIEVABLE],
                reallocations=self._reallocations,
                open_at_end=self._outcomes[ev.OPEN_AT_END],
                charging=states.count(timeline.CHARGING),
                failed_robots=states.count(timeline.FAILED),
                lowest_battery_percent=min(self._battery.values()) if self._battery else None,
            )


def eta_s(p: Progress, duration_s: float | None) -> float | None:
    """Wall seconds left at the pace so far (None before there is a pace)."""
    rtf = p.real_time_factor
    if duration_s is None or rtf is None or rtf <= 0 or p.sim_s <= 0:
        return None
    return max(0.0, duration_s - p.sim_s) / rtf


def bar_text(p: Progress, duration_s: float | None) -> str:
    """The figures beside the bar: simulated time of the total, percent and ETA."""
    if duration_s is None or duration_s <= 0:
        return f"sim {hms(p.sim_s)}"
    left = eta_s(p, duration_s)
    eta = hms(left) if left is not None else "-:--:--"
    pct = min(100.0, 100.0 * p.sim_s / duration_s)
    return f"sim {hms(p.sim_s)} / {hms(duration_s)}  {pct:3.0f}%  ETA {eta}"


def make_bar(p: Progress, duration_s: float | None, width: int = 40) -> RenderableType:
    total = duration_s if duration_s and duration_s > 0 else None
    bar = ProgressBar(total=total, completed=min(p.sim_s, total or p.sim_s), width=width)
    row = Table.grid(padding=(0, 1))
    row.add_row(bar, Text(bar_text(p, duration_s)))
    return row


def format_line(p: Progress, duration_s: float | None = None) -> str:
    rtf = f"{p.real_time_factor:.1f}" if p.real_time_factor is not None else "-"
    battery = (
        f"{p.lowest_battery_percent:.0f}%" if p.lowest_battery_percent is not None else "-"
    )
    sim = bar_text(p, duration_s) if duration_s else f"sim {hms(p.sim_s)}"
    return (
        f"{sim} | wall {hms(p.wall_s)} | rtf {rtf} | tasks introduced "
        f"{p.introduced} allocated {p.allocated} completed {p.completed} "
        f"unachievable {p.unachievable} failed {p.failed} | charging {p.charging} | "
        f"lowest battery {battery}"
    )


def make_table(p: Progress, title: str = "") -> Table:
    rtf = f"{p.real_time_factor:.1f}" if p.real_time_factor is not None else "-"
    battery = (
        f"{p.lowest_battery_percent:.0f}%" if p.lowest_battery_percent is not None else "-"
    )
    table = Table(title=title or None, show_header=False, min_width=36)
    table.add_column("figure", style="bold")
    table.add_column("value", justify="right")
    rows = (
        ("simulation time", hms(p.sim_s)),
        ("wall time", hms(p.wall_s)),
        ("real-time factor", rtf),
        ("tasks introduced", str(p.introduced)),
        ("tasks allocated", str(p.allocated)),
        ("tasks completed", str(p.completed)),
        ("tasks unachievable", str(p.unachievable)),
        ("tasks failed", str(p.failed)),
        ("tasks open at end", str(p.open_at_end)),
        ("reallocations", str(p.reallocations)),
        ("robots charging", str(p.charging)),
        ("robots down", str(p.failed_robots)),
        ("lowest battery", battery),
    )
    for name, value in rows:
        table.add_row(name, value)
    return table


class ProgressDisplay:
    """Shows a tracker's figures. `start()`, call `tick()` whenever convenient, `stop()`.

    `wall_clock` gives seconds (monotonic); `stream` is where plain lines go.
    """

    def __init__(
        self,
        tracker: ProgressTracker,
        *,
        wall_clock: Callable[[], float],
        stream: TextIO,
        terminal: bool | None = None,
        line_period_sim_s: float = 300.0,
        refresh_per_second: float = 4.0,
        title: str = "",
        duration_s: float | None = None,
        first_line_wall_s: float = 1.0,
    ) -> None:
        self._tracker = tracker
        self._clock = wall_clock
        self._t0 = wall_clock()
        self._stream = stream
        self._title = title
        self._console = Console(file=stream, force_terminal=terminal)
        self.terminal = self._console.is_terminal
        self._period = line_period_sim_s
        self._next_line_s = line_period_sim_s
        self._live: Live | None = None
        self._refresh = refresh_per_second
        self._lock = threading.Lock()
        self.lines_written = 0
        self.duration_s = duration_s
        self._first_line_wall_s = first_line_wall_s
        self._first_line_done = False

    def snapshot(self) -> Progress:
        return self._tracker.progress(self._clock() - self._t0)

    def _renderable(self) -> RenderableType:
        p = self.snapshot()
        return Group(make_bar(p, self.duration_s), make_table(p, self._title))

    def start(self) -> None:
        if self.terminal:
            self._live = Live(
                get_renderable=self._renderable,
                console=self._console,
                refresh_per_second=self._refresh,
                transient=False,
            )
            self._live.start()
        else:
            # at once, so that a log or a pipe shows the run is alive
            length = f" for {hms(self.duration_s)} simulated" if self.duration_s else ""
            with self._lock:
                self._stream.write(f"{self._title or 'run'}: started{length}\n")
                self._stream.flush()

    def tick(self) -> None:
        """Write a plain line when another period of simulation time has passed."""
        if self.terminal:
            return
        p = self.snapshot()
        with self._lock:
            if not self._first_line_done and p.wall_s >= self._first_line_wall_s:
                # the first figures after about a second, whatever the simulated time
                self._first_line_done = True
                self._write(p)
                return
            if p.sim_s < self._next_line_s:
                return
            while self._next_line_s <= p.sim_s:
                self._next_line_s += self._period
            self._write(p)

    def _write(self, p: Progress) -> None:
        self._stream.write(format_line(p, self.duration_s) + "\n")
        self._stream.flush()
        self.lines_written += 1

    def stop(self) -> Progress:
        """Stop the live table (or write the final plain line); returns the last figures."""
        p = self.snapshot()
        if self._live is not None:
            self._live.stop()
            self._live = None
        else:
            with self._lock:
                self._write(p)
        return p

    def __enter__(self) -> ProgressDisplay:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
