"""An in-memory bus with the multicast transport's semantics and injectable faults.

Every endpoint gets every datagram published on the bus (its own included), through the same
encode/sign/decode pipeline as multicast, so subject matching, counters, size limits and
authentication behave identically. Faults are drawn from the `random.Random` passed in:

- `loss`: probability that one receiver misses one datagram;
- `duplicate`: probability that a receiver gets a second copy (with its own delay);
- `delay_s`: (min, max) uniform one-way delay per receiver copy, which reorders datagrams
  whenever max > min;
- `reorder`/`reorder_hold_s`: probability that a copy is held back an extra `reorder_hold_s`;
- `MemoryBus.set_link(sender_id, up)`: cut an endpoint off (both directions) and restore it.

Time is the injected clock's: a datagram becomes due at publish time plus its delay and is
delivered by `poll()` on its receiving endpoint (or `MemoryBus.deliver_due()` for all) once the
clock has reached that time. Nothing here waits.
"""

from __future__ import annotations

import heapq
import random
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from murdoch.auth import TeamKey
from murdoch.transport import (
    Clock,
    EndpointBacked,
    EndpointCore,
)
from murdoch.wire import Codec


@dataclass(frozen=True)
class NetworkFaults:
    loss: float = 0.0
    duplicate: float = 0.0
    delay_s: tuple[float, float] = (0.0, 0.0)
    reorder: float = 0.0
    reorder_hold_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("loss", "duplicate", "reorder"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be a probability, got {value}")
        low, high = self.delay_s
        if not 0.0 <= low <= high:
            raise ValueError(f"delay_s must be (min, max) with 0 <= min <= max, got {self.delay_s}")
        if self.reorder_hold_s < 0.0:
            raise ValueError("reorder_hold_s must be >= 0")

    @property
    def max_delay_s(self) -> float:
        return self.delay_s[1] + (self.reorder_hold_s if self.reorder > 0 else 0.0)


class MemoryBus:
    """A shared medium for `MemoryTransport` endpoints in one process."""

    def __init__(
        self, clock: Clock, rng: random.Random, faults: NetworkFaults | None = None
    ) -> None:
        self.clock = clock
        self.rng = rng
        self.faults = faults or NetworkFaults()
        self._endpoints: dict[str, MemoryTransport] = {}
        self._down: set[str] = set()
        self._order = 0
        self.datagrams_lost = 0
        self.datagrams_duplicated = 0

    def endpoint(
        self, sender_id: str, codec: Codec | None = None, key: TeamKey | None = None
    ) -> MemoryTransport:
        if sender_id in self._endpoints:
            raise ValueError(f"an endpoint named {sender_id!r} is already on the bus")
        transport = MemoryTransport(self, sender_id, codec, key)
        self._endpoints[sender_id] = transport
        return transport

    def detach(self, sender_id: str) -> None:
        self._endpoints.pop(sender_id, None)
        self._down.discard(sender_id)

    def set_link(self, sender_id: str, up: bool) -> None:
        """Cut `sender_id` off the bus (nothing in or out) or bring it back."""
        if up:
            self._down.discard(sender_id)
        else:
            self._down.add(sender_id)

    def inject(self, datagram: bytes, to: Iterable[str] | None = None) -> None:
        """Put raw bytes on the wire (for tests of forged or malformed traffic)."""
        targets = self._endpoints if to is None else {k: self._endpoints[k] for k in to}
        now = self.clock()
        for transport in list(targets.values()):
            self._enqueue(transport, now, datagram)

    def broadcast(self, datagram: bytes, sender_id: str) -> None:
        now = self.clock()
        faults = self.faults
        if sender_id in self._down:
            self.datagrams_lost += len(self._endpoints)
            return
        for name, transport in list(self._endpoints.items()):
            if name in self._down:
                self.datagrams_lost += 1
                continue
            if faults.loss and self.rng.random() < faults.loss:
                self.datagrams_lost += 1
                continue
            self._enqueue(transport, now + self._delay(), datagram)
            if faults.duplicate and self.rng.random() < faults.duplicate:
                self.datagrams_duplicated += 1
                self._enqueue(transport, now + self._delay(), datagram)

    def _delay(self) -> float:
        low, high = self.faults.delay_s
        delay = low if high == low else self.rng.uniform(low, high)
        if self.faults.reorder and self.rng.random() < self.faults.reorder:
            delay += self.faults.reorder_hold_s
        return delay

    def _enqueue(self, transport: MemoryTransport, due: float, datagram: bytes) -> None:
        self._order += 1
        heapq.heappush(transport._inbox, (due, self._order, datagram))

    def deliver_due(self) -> int:
        """Deliver every due datagram on every endpoint; return deliveries made."""
        return sum(t.poll() for t in list(self._endpoints.values()))

    def next_due(self) -> float | None:
        dues = [t._inbox[0][0] for t in self._endpoints.values() if t._inbox]
        return min(dues) if dues else None

    @property
    def pending(self) -> int:
        return sum(len(t._inbox) for t in self._endpoints.values())


class MemoryTransport(EndpointBacked):
    """One endpoint on a `MemoryBus`; implements the `Transport` interface."""

    def __init__(
        self, bus: MemoryBus, sender_id: str, codec: Codec | None, key: TeamKey | None
    ) -> None:
        from murdoch.auction.messages import AUCTION_CODEC

        self._bus = bus
        instance = f"{bus.rng.getrandbits(32):08x}"
        self._core = EndpointCore(sender_id, codec or AUCTION_CODEC, bus.clock, key,
                                  instance=instance)
        self._inbox: list[tuple[float, int, bytes]] = []
        self.closed = False

    def publish(self, subjects: Iterable[str] | str, message: Any) -> int:
        if self.closed:
            raise RuntimeError("transport is closed")
        data = self._core.encode(subjects, message)
        self._bus.broadcast(data, self.sender_id)
        return len(data)

    def poll(self, timeout_s: float = 0.0) -> int:
        """Deliver datagrams due by now (never waits: time is the injected clock's)."""
        del timeout_s
        now = self._bus.clock()
        delivered = 0
        while self._inbox and self._inbox[0][0] <= now and not self.closed:
            _, _, datagram = heapq.heappop(self._inbox)
            delivered += self._core.receive(datagram)
        return delivered

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._inbox.clear()
            self._bus.detach(self.sender_id)
