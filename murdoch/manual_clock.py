"""A clock that moves only when told to: runs on the in-memory bus, the contract checker."""

from __future__ import annotations


class ManualClock:
    """A clock that moves only when told to (for runs on the in-memory bus)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.now_s = start_s

    def __call__(self) -> float:
        return self.now_s

    def advance(self, dt_s: float) -> None:
        self.now_s += dt_s
