"""Which transport a process opens: UDP multicast (the default) or Zenoh (optional).

The one place that turns a `--transport` choice into a transport, for every command that
offers it (`murdoch listen`/`announce`, `murdoch-robot`, `murdoch run`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

from murdoch.endpoint import EndpointOptions
from murdoch.lossy import LossyReceiver
from murdoch.multicast import MulticastConfig, MulticastTransport
from murdoch.transport import Clock, Transport
from murdoch.zenoh_transport import ZenohConfig, ZenohTransport

TRANSPORTS = ("multicast", "zenoh")
DEFAULT_TRANSPORT = "multicast"


class TeamTransport(Transport, Protocol):
    """A transport that can also act as a lockstep release point."""

    def settle_tick(self, tick: int, table: Mapping[str, int], *, wait_clock: Clock,
                    give_up_after_s: float = 60.0) -> int: ...


@dataclass(frozen=True)
class TransportChoice:
    """`kind` and the settings of that kind (the other one's are ignored)."""

    kind: str = DEFAULT_TRANSPORT
    multicast: MulticastConfig = field(default_factory=MulticastConfig)
    zenoh: ZenohConfig = field(default_factory=ZenohConfig)

    def __post_init__(self) -> None:
        if self.kind not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, found "
                             f"{self.kind!r}")

    def describe(self) -> str:
        if self.kind == "zenoh":
            role = "hub listening on" if self.zenoh.hub else "client of"
            return f"zenoh {role} {self.zenoh.endpoint} ({self.zenoh.key_expr})"
        return f"multicast {self.multicast.group}:{self.multicast.port}"


def open_transport(
    choice: TransportChoice,
    sender_id: str,
    clock: Clock,
    options: EndpointOptions | None = None,
    *,
    loss: LossyReceiver | None = None,
) -> MulticastTransport | ZenohTransport:
    """Open the chosen transport (a loss layer exists for multicast only)."""
    if choice.kind == "zenoh":
        if loss is not None:
            raise ValueError("a bus loss layer is available on the multicast transport only")
        return ZenohTransport(sender_id, clock, choice.zenoh, options)
    return MulticastTransport(sender_id, clock, choice.multicast, options, loss=loss)
