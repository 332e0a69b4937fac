"""Rate-limited logging: a flood of the same complaint costs a few lines, not one each.

``LogLimiter.log(key, ...)`` writes at most ``burst`` lines per ``period_s`` for each key
(a short category such as "bad message", never a per-client value, so the table stays
small); the first line of the next period says how many were held back. The caller keeps
its own counters: the limiter only decides what reaches the log.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any


class _Window:
    __slots__ = ("count", "start", "suppressed")

    def __init__(self, start: float) -> None:
        self.start = start
        self.count = 0
        self.suppressed = 0


class LogLimiter:
    def __init__(self, logger: logging.Logger, *, burst: int = 5, period_s: float = 10.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._log = logger
        self.burst = burst
        self.period_s = period_s
        self._clock = clock
        self._windows: dict[str, _Window] = {}
        #: lines held back since start, over every key
        self.suppressed = 0

    def log(self, key: str, level: int, msg: str, *args: Any, exc_info: bool = False) -> bool:
        """Log unless ``key`` already had ``burst`` lines this period; True if logged."""
        now = self._clock()
        w = self._windows.get(key)
        if w is None or now - w.start >= self.period_s:
            held = w.suppressed if w is not None else 0
            w = _Window(now)
            self._windows[key] = w
            if held:
                self._log.log(level, "(%d more %r lines were suppressed in the last %.0f s)",
                              held, key, self.period_s)
        if w.count >= self.burst:
            w.suppressed += 1
            self.suppressed += 1
            return False
        w.count += 1
        self._log.log(level, msg, *args, exc_info=exc_info)
        return True
