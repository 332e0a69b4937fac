"""The server core's lockstep gate: who holds the simulation's clock, and whether it may step.

`LockstepGate` is the part of `player_server.server.core.ServerCore` that decides, in
lockstep, which sessions are participants and whether every one of them has asked for the
next round (docs/player.md, "Lockstep"); a participant that holds the clock too long is
demoted to a monitor.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from player_server.protocol import constants as c
from player_server.protocol.constants import Interface

if TYPE_CHECKING:
    from player_server.server.session import CoreConfig, CoreCounters, Session

# the core's logger: these are its messages
log = logging.getLogger("player_server.server.core")

_POSITION2D = int(Interface.POSITION2D)
#: a client that has not had its first round yet holds the clock this many times longer
_FIRST_ROUND_GRACE = 4.0


class LockstepGate:
    """The lockstep of `ServerCore` (which provides what is declared below)."""

    if TYPE_CHECKING:
        config: CoreConfig
        counters: CoreCounters
        sessions: dict[int, Session]
        round_seq: int
        participants_seen: int
        expected: dict[str, Callable[[], bool]]

    def is_participant(self, s: Session) -> bool:
        if not self.config.lockstep or s.closing is not None or s.demoted:
            return False
        if s.lockstep_override is not None:
            return s.lockstep_override
        return s.mode == c.PLAYER_DATAMODE_PULL and any(
            k[0] == _POSITION2D for k in s.subs)

    def expect(self, endpoint_name: str, alive: Callable[[], bool] = lambda: True) -> None:
        """Step no further until a participant has joined on this endpoint (a robot process
        started by the owner) and asked for a round, like every other participant, or
        until `alive()` says it never will."""
        self.expected[endpoint_name] = alive

    def participants(self) -> list[Session]:
        return [s for s in self.sessions.values() if self.is_participant(s)]

    def lockstep_ready(self, now_s: float) -> bool:
        """May the simulation step? (Always true when lockstep is off.)"""
        if not self.config.lockstep:
            return True
        parts = self.participants()
        for s in parts:
            if not s.counted_as_participant:
                s.counted_as_participant = True
                self.participants_seen += 1
        if self.participants_seen < self.config.lockstep_clients or (
                not parts and not self.config.step_without_participants):
            return False
        if self.expected:
            joined = {s.endpoint.name for s in parts}
            for name, alive in list(self.expected.items()):
                if name in joined or not alive():
                    del self.expected[name]
            if self.expected:
                return False
        laggards = [s for s in parts
                    if not (s.round_pending and s.last_round >= self.round_seq)]
        if not laggards:
            return True
        timeout = self.config.lockstep_timeout_s
        if timeout > 0:
            for s in laggards:
                # a client still setting up (no round yet) gets a longer grace
                limit = timeout if s.last_round >= 0 else _FIRST_ROUND_GRACE * timeout
                if s.stalled_since is None:
                    s.stalled_since = now_s
                elif now_s - s.stalled_since > limit:
                    log.warning("lockstep: client %s on %s kept the simulation waiting "
                                "for %.1f s; it no longer holds the clock until it asks "
                                "for data again", s.peer, s.endpoint.name,
                                now_s - s.stalled_since)
                    s.demoted = True
                    s.stalled_since = None
                    self.counters.demoted += 1
        return False
