"""Pace simulation ticks against wall time: speedup 1 is real time, 0 as fast as possible."""

from __future__ import annotations

from collections.abc import Callable


class Pacer:
    """Sleeps (with the injected sleep) until wall time catches up with simulated time."""

    def __init__(self, interval_s: float, speedup: float, clock: Callable[[], float],
                 sleep: Callable[[float], None]) -> None:
        if speedup < 0:
            raise ValueError("speedup must be >= 0")
        self.interval_s = interval_s
        self.speedup = speedup
        self._clock = clock
        self._sleep = sleep
        self._start_wall = clock()
        self._start_tick = 0

    def restart(self, tick: int) -> None:
        """Re-anchor (after a pause or a change of speedup) at the given tick."""
        self._start_wall = self._clock()
        self._start_tick = tick

    def set_speedup(self, speedup: float, tick: int) -> None:
        if speedup < 0:
            raise ValueError("speedup must be >= 0")
        self.speedup = speedup
        self.restart(tick)

    def wall_due(self, tick: int) -> float:
        """Wall-clock time at which ``tick`` is due."""
        if self.speedup == 0:
            return self._start_wall
        return self._start_wall + (tick - self._start_tick) * self.interval_s / self.speedup

    def wait(self, tick: int) -> float:
        """Block until ``tick`` is due; returns the seconds slept (0 when running late)."""
        if self.speedup == 0:
            return 0.0
        delay = self.wall_due(tick) - self._clock()
        if delay > 0:
            self._sleep(delay)
            return delay
        return 0.0
