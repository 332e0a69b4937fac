"""The team clock device (opaque:0) of a lockstep experiment run.

The runner adds it to every robot's port. A robot process sends its `Declaration` (how many
MURDOCH datagrams it has sent in all) as opaque CMD 2 before it asks for the next round; the
count is accepted only for a sender key named after the port's robot, and never decreases.
Every round carries the whole `TeamClock` table as opaque DATA 1, read at publish time (it is
a *live* device: its data is not cached with the rest of a round). The runner declares its
own node's count straight into the same table. See `player_server.protocol.team_clock`.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from player_server.drivers.base import Driver, Unsupported
from player_server.protocol import constants as c
from player_server.protocol.constants import Interface
from player_server.protocol.sensor_msgs import OpaqueData
from player_server.protocol.team_clock import Declaration, check_count, check_key, encode_table

log = logging.getLogger(__name__)


class TeamClock:
    """The participants' datagram counts (one table shared by every robot's port)."""

    def __init__(self, max_senders: int = 4096) -> None:
        self._counts: dict[str, int] = {}
        self._encoded: bytes | None = None
        self.max_senders = max_senders
        self.rejected = 0

    def declare(self, key: str, count: int) -> None:
        check_key(key)
        check_count(count)
        old = self._counts.get(key)
        if old is not None and count < old:
            raise ValueError(f"{key} declared {count} datagrams after {old}")
        if old is None and len(self._counts) >= self.max_senders:
            raise ValueError("too many senders")
        if old != count:
            self._counts[key] = count
            self._encoded = None

    def table(self) -> dict[str, int]:
        return dict(self._counts)

    def encoded(self) -> bytes:
        if self._encoded is None:
            self._encoded = encode_table(self._counts)
        return self._encoded


class TeamClockDriver(Driver):
    interf = int(Interface.OPAQUE)
    commands = frozenset({c.PLAYER_OPAQUE_CMD_DATA})
    deferred_commands = frozenset({c.PLAYER_OPAQUE_CMD_DATA})
    live = True

    def __init__(self, clock: TeamClock, robot: str, index: int = 0) -> None:
        super().__init__(index, "team_clock")
        self.clock = clock
        self.robot = robot
        self._last: tuple[bytes, OpaqueData] | None = None

    def data(self) -> Sequence[tuple[int, Any]]:
        payload = self.clock.encoded()
        last = self._last
        if last is None or last[0] is not payload:
            last = (payload, OpaqueData(payload))
            self._last = last
        return ((c.PLAYER_OPAQUE_DATA_STATE, last[1]),)

    def handle_command(self, subtype: int, body: Any) -> None:
        if subtype != c.PLAYER_OPAQUE_CMD_DATA or not isinstance(body, OpaqueData):
            raise Unsupported(f"command {subtype}")
        try:
            decl = Declaration.decode(bytes(body.data))
            if decl.key.partition("/")[0] != self.robot:
                raise ValueError(f"{self.robot}'s port cannot declare for {decl.key}")
            self.clock.declare(decl.key, decl.count)
        except ValueError as exc:
            self.clock.rejected += 1
            if self.clock.rejected <= 10:
                log.warning("team clock: refused a declaration on %s: %s", self.robot, exc)
            raise Unsupported(str(exc)) from None
