"""A client's bounded outgoing queue of encoded messages.

Replies and SYNCH are never dropped. DATA follows the client's replace rules: REPLACE
removes an older queued DATA with the same (interface, index, type, subtype) (the latest
value wins), IGNORE drops it, ACCEPT queues it. When more than ``limit`` DATA are
queued, the oldest DATA is dropped and counted.

A replaced or dropped entry lets go of its bytes at once, and the queue is compacted when
dead entries outnumber live ones, so a client that never reads holds at most what is
live in its queue (``nbytes``; the core closes it past its output limit).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

DataKey = tuple[int, int, int, int]

_EMPTY = b""
#: dead entries tolerated before a compaction is considered
_COMPACT_MIN = 64


class _Entry:
    __slots__ = ("alive", "key", "wire")

    def __init__(self, wire: bytes, key: DataKey | None) -> None:
        self.wire = wire
        self.key = key
        self.alive = True


@dataclass(frozen=True)
class QueueStats:
    depth: int
    peak: int
    replaced: int
    dropped: int
    replies_waiting: int
    nbytes: int


class OutQueue:
    def __init__(self, limit: int = 1024) -> None:
        self._entries: deque[_Entry] = deque()
        self._latest: dict[DataKey, _Entry] = {}
        self._limit = limit
        self._data_count = 0
        self._reply_count = 0
        self._dead = 0
        #: bytes of the live entries
        self.nbytes = 0
        self.peak = 0
        self.replaced = 0
        self.dropped = 0

    def __len__(self) -> int:
        return self._data_count + self._reply_count

    @property
    def replies_waiting(self) -> int:
        return self._reply_count

    @property
    def entries_held(self) -> int:
        """Live and dead entries still in the deque (what compaction keeps bounded)."""
        return len(self._entries)

    def push_reply(self, wire: bytes) -> None:
        """A reply or SYNCH: always queued, in order."""
        self._entries.append(_Entry(wire, None))
        self._reply_count += 1
        self.nbytes += len(wire)
        self._note_peak()

    def push_data(self, key: DataKey, wire: bytes, replace: bool) -> None:
        if replace:
            old = self._latest.get(key)
            if old is not None and old.alive:
                self._kill(old)
                self.replaced += 1
        entry = _Entry(wire, key)
        self._entries.append(entry)
        self._latest[key] = entry
        self._data_count += 1
        self.nbytes += len(wire)
        if self._data_count > self._limit:
            self._drop_oldest_data()
        self._note_peak()
        self._maybe_compact()

    def _kill(self, e: _Entry) -> None:
        """Mark a DATA entry dead and let go of its bytes."""
        e.alive = False
        self.nbytes -= len(e.wire)
        e.wire = _EMPTY
        self._data_count -= 1
        self._dead += 1

    def _drop_oldest_data(self) -> None:
        for e in self._entries:
            if e.alive and e.key is not None:
                self._kill(e)
                self.dropped += 1
                return

    def _maybe_compact(self) -> None:
        live = self._data_count + self._reply_count
        if self._dead > _COMPACT_MIN and self._dead > live:
            self._entries = deque(e for e in self._entries if e.alive)
            self._dead = 0

    def _note_peak(self) -> None:
        n = self._data_count + self._reply_count
        if n > self.peak:
            self.peak = n

    def take(self, max_bytes: int = 1 << 20) -> bytes:
        """Remove and return queued messages, whole, up to about ``max_bytes``."""
        entries = self._entries
        if len(entries) == 1 and entries[0].key is None:
            # one reply alone (a request's answer): no join
            wire = entries.popleft().wire
            self._reply_count -= 1
            self.nbytes -= len(wire)
            return wire
        parts: list[bytes] = []
        total = 0
        while entries and total < max_bytes:
            e = entries.popleft()
            if not e.alive:
                self._dead -= 1
                continue
            if e.key is None:
                self._reply_count -= 1
            else:
                self._data_count -= 1
                if self._latest.get(e.key) is e:
                    del self._latest[e.key]
            parts.append(e.wire)
            total += len(e.wire)
        self.nbytes -= total
        if len(parts) == 1:
            return parts[0]
        return b"".join(parts)

    def clear_data(self) -> None:
        for e in self._entries:
            if e.alive and e.key is not None:
                self._kill(e)
        self._latest.clear()
        self._maybe_compact()

    def clear(self) -> None:
        """Drop everything (the client is being disconnected)."""
        self._entries.clear()
        self._latest.clear()
        self._data_count = self._reply_count = self._dead = 0
        self.nbytes = 0

    def stats(self) -> QueueStats:
        return QueueStats(len(self), self.peak, self.replaced, self.dropped,
                          self._reply_count, self.nbytes)
