"""An endpoint: one listening port serving one robot's devices."""

from __future__ import annotations

from dataclasses import dataclass

from player_server.drivers.base import Driver
from player_server.protocol.constants import interface_name


@dataclass
class Endpoint:
    """A robot (or the overhead camera) and its drivers keyed by (interface, index).

    ``port`` is the port actually bound (filled in by the TCP front end when the requested
    port is 0); it is also the ``robot`` field of every device address.
    """

    name: str
    drivers: dict[tuple[int, int], Driver]
    requested_port: int = 0
    port: int = 0
    mobile: bool = True

    def device_names(self) -> list[str]:
        return [f"{interface_name(i)}:{x}" for (i, x) in self.drivers]
