"""Which sensors a tick's sensing pass computes: those expected to be read in it.

A sensor read every tick (a robot's sonar, its blobfinder) is expected in every tick; one read
every k ticks (a recording's laser at 2 Hz in a 10 Hz world) in every k-th, counted from its
last read; one read once, or at irregular times, is computed when it is read. What is computed
together or apart changes no reading (each ray's distance depends on that ray alone): the
schedule only saves casting rays that nobody reads.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)


class ReadSchedule(Generic[K]):
    """Notes each sensor's reads by tick and answers which are due in a tick."""

    def __init__(self) -> None:
        self._last: dict[K, int] = {}  # the tick of each sensor's last read
        self._due: dict[int, set[K]] = {}  # tick -> sensors expected then
        self._tick = -1
        self._read_now: set[K] = set()
        self._expected: tuple[frozenset[K], tuple[K, ...]] = (frozenset(), ())

    def note(self, key: K, tick: int) -> None:
        """`key` is read in `tick` (ticks do not go back)."""
        if tick != self._tick:
            self._tick = tick
            self._read_now = set()
            for old in [t for t in self._due if t < tick]:
                del self._due[old]
        if key in self._read_now:
            return
        self._read_now.add(key)
        last = self._last.get(key)
        self._last[key] = tick
        if last is not None and last < tick:
            self._due.setdefault(tick + (tick - last), set()).add(key)

    def expected(self, tick: int) -> tuple[K, ...]:
        """The sensors due in `tick` and those read in it so far, sorted (the same tuple while
        they do not change)."""
        keys = set(self._due.get(tick, ()))
        if tick == self._tick:
            keys |= self._read_now
        frozen = frozenset(keys)
        if frozen != self._expected[0]:
            self._expected = (frozen, tuple(sorted(keys)))  # type: ignore[type-var]
        return self._expected[1]

    def known(self) -> frozenset[K]:
        """Every sensor ever read."""
        return frozenset(self._last)
