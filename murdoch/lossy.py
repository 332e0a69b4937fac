"""A seeded loss layer for a receiver of the MURDOCH bus (real-time runs only).

Each datagram a receiver reads is dropped with probability `loss`, or else held back for a
uniform 0..`delay_s` wall seconds before it is handed on (so datagrams also overtake one
another). The draws come from the receiver's own seeded generator, so the loss pattern depends
only on the seed, the receiver and the order of arrivals. In lockstep a datagram that never
arrives is an error by design (the tick protocol), so this layer is refused there.
"""

from __future__ import annotations

import heapq
import random
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field

ENV = "MURDOCH_BUS_LOSS"
"""`LOSS,DELAY_S,SEED` in a robot process's environment turns the layer on."""


@dataclass(frozen=True)
class LossSpec:
    loss: float
    delay_s: float
    seed: int

    def __post_init__(self) -> None:
        if not 0.0 <= self.loss < 1.0:
            raise ValueError(f"loss must be in [0, 1), found {self.loss}")
        if not 0.0 <= self.delay_s <= 60.0:
            raise ValueError(f"delay must be 0..60 s, found {self.delay_s}")

    @staticmethod
    def parse(text: str) -> LossSpec:
        """'0.02,0.05,13' -> LossSpec(0.02, 0.05, 13)."""
        parts = text.split(",")
        try:
            if len(parts) != 3:
                raise ValueError("three fields")
            return LossSpec(float(parts[0]), float(parts[1]), int(parts[2]))
        except ValueError as exc:
            raise ValueError(f"{ENV}: expected LOSS,DELAY_S,SEED such as 0.02,0.05,13, "
                             f"found {text!r} ({exc})") from exc

    def as_text(self) -> str:
        return f"{self.loss},{self.delay_s},{self.seed}"


@dataclass
class LossyReceiver:
    """Stands between a socket and the endpoint: `offer` each datagram read, `due` hands on
    the ones whose delay has passed."""

    spec: LossSpec
    receiver: str
    clock: Callable[[], float]
    dropped: int = 0
    delayed: int = 0
    _rng: random.Random = field(init=False)
    _held: list[tuple[float, int, bytes]] = field(default_factory=list)
    _n: int = 0

    def __post_init__(self) -> None:
        self._rng = random.Random(self.spec.seed * 1_000_003 + zlib.crc32(
            self.receiver.encode()))

    def offer(self, datagram: bytes) -> None:
        if self._rng.random() < self.spec.loss:
            self.dropped += 1
            return
        wait = self._rng.uniform(0.0, self.spec.delay_s) if self.spec.delay_s > 0 else 0.0
        if wait > 0:
            self.delayed += 1
        self._n += 1
        heapq.heappush(self._held, (self.clock() + wait, self._n, datagram))

    def due(self) -> list[bytes]:
        now = self.clock()
        out = []
        while self._held and self._held[0][0] <= now:
            out.append(heapq.heappop(self._held)[2])
        return out

    def pending(self) -> int:
        return len(self._held)
