"""What the transports share beyond `EndpointCore`: their options and, for the transports
that carry datagrams between processes, the lockstep release point and closing.

Every transport (multicast, Zenoh, and `open_transport`, which picks one of them) takes the
same settings for its `EndpointCore`: the codec of the message classes, the team key that
signs and checks datagrams, the instance label and the lockstep tick stamping. They travel
together as one `EndpointOptions`, and `core` builds the endpoint from them.
`NetworkEndpoint` is the part multicast and Zenoh have in common above the bytes they move.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Self

from murdoch.auth import TeamKey
from murdoch.transport import Clock, EndpointBacked, EndpointCore, TickConfig
from murdoch.wire import Codec


@dataclass(frozen=True)
class EndpointOptions:
    """`codec`: the message classes (None: the auction's); `key`: signs every datagram and
    checks what arrives (None: unsigned); `instance`: this process's label (None: drawn at
    random); `ticks`: lockstep tick stamping (None: none)."""

    codec: Codec | None = None
    key: TeamKey | None = None
    instance: str | None = None
    ticks: TickConfig | None = None

    def core(self, sender_id: str, clock: Clock) -> EndpointCore:
        """The endpoint of `sender_id` reading time from `clock`."""
        from murdoch.auction.messages import AUCTION_CODEC

        return EndpointCore(sender_id, self.codec or AUCTION_CODEC, clock, self.key,
                            instance=self.instance, ticks=self.ticks)


class NetworkEndpoint(EndpointBacked, ABC):
    """A transport between processes: it reads what has arrived (`poll`), can block until
    input may have arrived (`_wait`) and holds resources until `close` (also on leaving a
    `with` block)."""

    @abstractmethod
    def poll(self, timeout_s: float = 0.0, max_datagrams: int = 10_000) -> int: ...

    @abstractmethod
    def _wait(self, timeout_s: float) -> None: ...

    @abstractmethod
    def close(self) -> None: ...

    def settle_tick(
        self, tick: int, table: Mapping[str, int], *, wait_clock: Clock,
        give_up_after_s: float = 60.0,
    ) -> int:
        """Lockstep (an ordered `TickConfig`): the release point of `tick`.

        `table` holds every sender's count of datagrams through tick-1. Reads until all of
        them have arrived, then acts on those stamped tick-1 or earlier, in tick order
        (`EndpointCore.release`). `wait_clock` (wall seconds) only bounds the wait: a
        datagram still missing after `give_up_after_s` raises `LostDatagrams`."""
        return self._core.settle(tick, table, poll=lambda: self.poll(0.0), wait=self._wait,
                                 wait_clock=wait_clock, give_up_after_s=give_up_after_s)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
