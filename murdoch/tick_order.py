"""Acting on datagrams at tick boundaries, in an order that does not depend on arrival.

In a lockstep run every participant (each robot, and the runner's own node) works through
simulation ticks one at a time. A datagram carries its sender's tick in its header
(`murdoch.wire`). A receiver does not act on a datagram when it arrives: `TickInbox.hold`
keeps it, and at one fixed point of its tick k the receiver `release`s everything stamped
k-1 or earlier, sorted by (tick, sender, instance, sequence). What it acts on at tick k is
then the same whatever the scheduler did.

That needs to know that every datagram stamped k-1 or earlier has arrived. Each sender
declares, before it asks for tick k, how many datagrams it has sent in all (its sequence
numbers run from 0 without gaps); the lockstep hub gathers these counts and hands every
participant the table with its data of tick k (the Player server's team clock device, see
`docs/experiments.md`). `missing(table)` says which senders' datagrams have not all arrived
yet; the receiver reads its socket until nothing is missing, or gives up after a bound and
reports the loss (`LostDatagrams`): a lockstep run never goes on with a hole in it.

A receiver that joins a run late (a robot restarted at tick F) cannot have heard what was
sent before it opened its socket. It acts on nothing stamped F or earlier, and the table it
gets at tick F+1 (the counts through F) is its baseline: from then on it needs every
datagram above those counts. Datagrams from senders that appear later are needed from their
first sequence number.

Pure bookkeeping: no sockets, no clocks; `murdoch.transport` drives it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


class LostDatagrams(RuntimeError):
    """Declared datagrams did not arrive in time: the lockstep run cannot go on exactly."""

    def __init__(self, tick: int, missing: Mapping[str, int]) -> None:
        detail = ", ".join(f"{k}: {n}" for k, n in sorted(missing.items()))
        super().__init__(f"at tick {tick}, datagrams never arrived from {detail}")
        self.tick = tick
        self.missing = dict(missing)


def sender_key(sender: str, instance: str) -> str:
    """How a sender instance is named in count tables: ``sender/instance``."""
    return f"{sender}/{instance}"


@dataclass(order=True)
class Held:
    """One datagram waiting for its release point (ordered by the release order)."""

    tick: int
    sender: str
    instance: str
    seq: int
    header: Any = field(compare=False)
    data: bytes = field(compare=False)


class TickInbox:
    """Datagrams received but not yet acted on, and which ones have arrived.

    `late_joiner`: this receiver may have missed datagrams sent before it opened its
    socket (a robot process); False for one that listens from before the run starts (the
    runner)."""

    def __init__(self, *, late_joiner: bool = True) -> None:
        self._held: list[Held] = []
        self._next: dict[str, int] = {}
        """Per sender instance: every sequence number below this has arrived (or is below
        the baseline)."""
        self._ahead: dict[str, set[int]] = {}
        """Per sender instance: numbers that arrived above a gap."""
        self._late = late_joiner
        self.first_tick: int | None = None
        self._baseline_set = not late_joiner
        self.duplicates = 0
        self.before_join = 0
        self.undeclared = 0
        self._satisfied: Mapping[str, int] | None = None
        """The last table found with nothing missing: arrivals only ever add to what is in,
        so the same table stays satisfied (a robot sees one table for many ticks)."""

    # -- arrival
    def hold(self, header: Any, data: bytes) -> bool:
        """Keep a datagram until its release point; False for a repeat (already held)."""
        key = sender_key(header.sender, header.instance)
        seq = header.seq
        nxt = self._next.get(key, 0)
        ahead = self._ahead.get(key)
        if seq < nxt or (ahead is not None and seq in ahead):
            self.duplicates += 1
            return False
        if seq == nxt:
            nxt += 1
            if ahead:
                while nxt in ahead:
                    ahead.discard(nxt)
                    nxt += 1
            self._next[key] = nxt
        else:
            self._ahead.setdefault(key, set()).add(seq)
        self._held.append(Held(header.tick, header.sender, header.instance, seq, header, data))
        return True

    # -- the release point
    def missing(self, table: Mapping[str, int]) -> dict[str, int]:
        """Sender instances with declared datagrams not yet arrived, and how many. A table
        passed here is not changed afterwards (each tick's table is a new mapping or the
        very same one as before)."""
        if not self._baseline_set or table is self._satisfied:
            return {}
        out: dict[str, int] = {}
        nxt = self._next
        for key, count in table.items():
            have = nxt.get(key, 0)
            if have < count:
                ahead = self._ahead.get(key, ())
                out[key] = count - have - sum(1 for s in ahead if s < count)
        if not out:
            self._satisfied = table
        return out

    def start(self, tick: int, table: Mapping[str, int]) -> None:
        """The receiver is at `tick` and has the count `table` of that tick (the counts
        through tick-1); call before `missing` and `release` at each tick."""
        if self.first_tick is None:
            self.first_tick = tick
            return
        if not self._baseline_set and tick > self.first_tick:
            # the counts through first_tick: what was sent before this receiver could hear
            # it is not needed, whether or not some of it arrived
            for key, count in table.items():
                nxt = max(self._next.get(key, 0), count)
                ahead = self._ahead.get(key)
                if ahead:
                    ahead.difference_update([s for s in ahead if s < nxt])
                    while nxt in ahead:
                        ahead.discard(nxt)
                        nxt += 1
                self._next[key] = nxt
            self._baseline_set = True

    def release(self, through_tick: int, table: Mapping[str, int]) -> list[Held]:
        """Every held datagram stamped `through_tick` or earlier, in release order.

        Datagrams from before this receiver joined are dropped (`before_join`); datagrams
        stamped that early whose sender never declared them (a sender that died between
        sending and declaring) are dropped as `undeclared`."""
        if not self._held:
            return []
        first = self.first_tick if self._late else None
        out: list[Held] = []
        keep: list[Held] = []
        for item in self._held:
            if item.tick > through_tick:
                keep.append(item)
            elif first is not None and item.tick <= first:
                self.before_join += 1
            elif item.seq >= table.get(sender_key(item.sender, item.instance), 0):
                self.undeclared += 1
            else:
                out.append(item)
        self._held = keep
        out.sort()
        return out

    @property
    def held(self) -> int:
        return len(self._held)
