"""Rate-limited log lines on an injected clock.

`RateLimitedLog(logger, interval_s)` writes at most one line per topic per `interval_s` of
the caller's clock (simulation seconds in a run); the lines held back in between are counted
and the next line written for that topic says how many there were::

    ratelog.warning("late_award", now, "award for %s arrived %.1f s late", task_id, late_s)
"""

from __future__ import annotations

import logging
from typing import Any


class RateLimitedLog:
    def __init__(self, logger: logging.Logger, interval_s: float = 10.0) -> None:
        if not interval_s > 0.0:
            raise ValueError(f"interval_s must be > 0, got {interval_s}")
        self._logger = logger
        self.interval_s = interval_s
        self._next_at: dict[str, float] = {}
        self._held: dict[str, int] = {}

    def warning(self, topic: str, now: float, message: str, *args: Any) -> bool:
        """Log `message % args` unless `topic` was logged less than `interval_s` ago;
        return whether it was written."""
        if now < self._next_at.get(topic, -float("inf")):
            self._held[topic] = self._held.get(topic, 0) + 1
            return False
        self._next_at[topic] = now + self.interval_s
        held = self._held.pop(topic, 0)
        if held:
            message += " (%d more since the last such line)"
            args = (*args, held)
        self._logger.warning(message, *args)
        return True
