"""What every allocator's member on the bus shares: the step skeleton, closing, sending.

A member's `step` takes the lock, polls the transport, hands each message that came to
`_handle` (all on one reading of the clock), then lets the member move on (`_advance`: its
timers, its tasks); `close` ends the subscription once. A send that fails is logged and
otherwise treated as a loss (the contract's silences cover it).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable

from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)


class BusMember:
    """The shell of a `TeamMember` that talks on the bus; subclasses say what a message
    means (`_handle`) and what a step does after the messages (`_advance`)."""

    def __init__(self, transport: Transport, clock: Clock, listen: Iterable[str]) -> None:
        self.transport = transport
        self.clock = clock
        self._lock = threading.RLock()
        self._sub = transport.subscribe(set(listen))
        self.closed = False

    def step(self, timeout_s: float = 0.0) -> int:
        with self._lock:
            if self.closed:
                return 0
            self.transport.poll(timeout_s)
            envelopes = self._sub.drain()
            now = self.clock()
            for envelope in envelopes:
                self._handle(envelope.message, now)
            self._advance(now)
            return len(envelopes)

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self.closed = True
                self._sub.close()

    def _handle(self, msg: object, now: float) -> None:
        raise NotImplementedError

    def _advance(self, now: float) -> None:
        raise NotImplementedError

    def _publish(self, subject: str, message: object) -> None:
        try:
            self.transport.publish({subject}, message)
        except OSError as exc:  # silence is handled like loss
            log.warning("could not send %s: %s", type(message).__name__, exc)
