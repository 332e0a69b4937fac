"""A consensus agent's state on the bus: offers instead of task indices (pure).

A robot's CBBA or CBGA agent plans over the offers it knows, in offer order (its local task
indices); the bus speaks of offers. `state_chunks` cuts an agent's message into
`ConsensusChunk`s that each cover a range of offer numbers (and fit one datagram);
`local_message` turns a received chunk back into the receiver's local indices, dropping what
it does not know (offers it never heard of or has seen withdrawn, winners it found silent).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Container, Sequence

from murdoch.allocators.team_messages import SESSION
from murdoch.consensus.async_runner import ConsensusChunk
from murdoch.consensus.messages import ConsensusMessage

ENTRIES_PER_CHUNK = 40
"""Entries (and group start times) per datagram: 40 of about 25 bytes each, with a team of
up to a few dozen stamps, stay well under the wire's limit."""
ALL_OFFERS = 1 << 31


def state_chunks(msg: ConsensusMessage, order: Sequence[int]) -> list[ConsensusChunk]:
    """The agent's message with local task indices replaced by offer numbers (`order`)."""
    stamps = tuple(None if not math.isfinite(t) else float(t) for t in msg.stamps)
    rows: dict[int, list[tuple[int, int, float]]] = {}
    for j, m, b in msg.entries:
        rows.setdefault(order[j], []).append((order[j], m, b))
    starts: dict[int, list[tuple[int, int, float]]] = {}
    for j, m, t in msg.starts:
        starts.setdefault(order[j], []).append((order[j], m, t))
    chunks: list[ConsensusChunk] = []
    first = 0
    entries: list[tuple[int, int, float]] = []
    times: list[tuple[int, int, float]] = []
    for offer in sorted(set(rows) | set(starts)):
        row, row_t = rows.get(offer, []), starts.get(offer, [])
        if (entries or times) and len(entries) + len(times) + len(row) + len(row_t) > \
                ENTRIES_PER_CHUNK:
            chunks.append(ConsensusChunk(SESSION, msg.sender, msg.time, first, offer - first,
                                         tuple(entries), stamps, tuple(times)))
            first, entries, times = offer, [], []
        entries.extend(row)
        times.extend(row_t)
    chunks.append(ConsensusChunk(SESSION, msg.sender, msg.time, first, ALL_OFFERS - first,
                                 tuple(entries), stamps, tuple(times)))
    return chunks


def local_message(chunk: ConsensusChunk, kind: int, order: Sequence[int],
                  silent: Container[int]) -> tuple[ConsensusMessage, tuple[int, int]]:
    """The chunk in local indices (`order`: the offers the receiver plans over, ascending)
    and the local range of tasks it covers."""
    local = {offer: j for j, offer in enumerate(order)}
    entries = tuple((local[o], m, b) for o, m, b in chunk.entries
                    if o in local and m not in silent)
    starts = tuple((local[o], m, t) for o, m, t in chunk.starts
                   if o in local and m not in silent)
    stamps = tuple(-math.inf if t is None else t for t in chunk.stamps)
    lo = bisect.bisect_left(order, chunk.first_task)
    hi = bisect.bisect_left(order, chunk.first_task + chunk.task_count)
    return ConsensusMessage(kind, chunk.sender, chunk.time, entries, stamps, starts), (lo, hi)
