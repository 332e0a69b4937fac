"""The `--refine` improvement phase for agents running asynchronously on the bus.

A `ConsensusNode` created with refine options runs the papers' algorithm first. Once its
own consensus state has not changed for `settle_periods` of its periods, it takes its path
and starts the phase of `refine.py` with a `RefineAgent`: from then on it publishes
`RefineChunk`s on the session's subject instead of its consensus state. Each period it
publishes its whole refine state again (the entries it holds for its current step and the
complete entries of the step before), so a lost, duplicated or reordered datagram costs
nothing but a period: an entry is kept the first time it arrives and a later copy is the
same. Agents are at most one step apart (no agent completes step t + 1 before every agent
has sent its entry of step t + 1, which it does only after completing step t), so the
previous step's entries are all a lagging neighbour can miss. An agent that has finished
keeps re-sending its last step until the run stops.

Chunks: entries are split over as many chunks as needed to stay under the datagram budget;
an entry is (author, kind, gain, data) with kind 0 = a path (data: its tasks), 1 = a
proposal (data: for each changed agent its index, its path length and its tasks), 2 = no
proposal. Everything received is checked against the problem's sizes; a chunk that does
not fit (unknown agent or task, a gain that is not finite) is dropped and counted.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

from murdoch.consensus.refine import Proposal, RefineAgent

Entry = tuple[int, int, float, tuple[int, ...]]
_PATH, _PROPOSAL, _NONE = 0, 1, 2
REFINE_BUDGET_BYTES = 1100


@dataclass(frozen=True)
class RefineChunk:
    """Part of one agent's refine state: entries of its current step and of the step
    before (`previous_step` -1: none)."""

    KIND: ClassVar[str] = "consensus-refine"
    session: str
    sender: int
    step: int
    entries: tuple[Entry, ...]
    previous_step: int
    previous: tuple[Entry, ...]


def encode_entries(entries: dict[int, object]) -> list[Entry]:
    out: list[Entry] = []
    for author, e in sorted(entries.items()):
        if isinstance(e, Proposal):
            data: list[int] = []
            for k, q in e.paths:
                data.extend((k, len(q), *q))
            out.append((author, _PROPOSAL, float(e.gain), tuple(data)))
        elif isinstance(e, tuple):
            out.append((author, _PATH, 0.0, tuple(int(j) for j in e)))
        else:
            out.append((author, _NONE, 0.0, ()))
    return out


def decode_entries(entries: Iterable[Entry], n_agents: int, n_tasks: int
                   ) -> dict[int, object] | None:
    """The entries as `RefineAgent` holds them; None when any entry is malformed."""
    out: dict[int, object] = {}
    for author, kind, gain, data in entries:
        if not 0 <= author < n_agents or not math.isfinite(gain):
            return None
        if any(not 0 <= j < max(n_tasks, n_agents) for j in data):
            return None
        if kind == _PATH:
            if any(j >= n_tasks for j in data) or len(set(data)) != len(data):
                return None
            out[author] = tuple(data)
        elif kind == _PROPOSAL:
            paths: list[tuple[int, tuple[int, ...]]] = []
            pos = 0
            while pos < len(data):
                if pos + 2 > len(data):
                    return None
                k, length = data[pos], data[pos + 1]
                q = tuple(data[pos + 2: pos + 2 + length])
                if k >= n_agents or len(q) != length or any(j >= n_tasks for j in q):
                    return None
                paths.append((k, q))
                pos += 2 + length
            if not paths:
                return None
            out[author] = Proposal(author, gain, tuple(paths))
        elif kind == _NONE:
            out[author] = None
        else:
            return None
    return out


def _split(entries: list[Entry], budget: int) -> list[list[Entry]]:
    parts: list[list[Entry]] = [[]]
    size = 0
    for e in entries:
        cost = 24 + 6 * len(e[3]) + len(repr(e[2]))
        if parts[-1] and size + cost > budget:
            parts.append([])
            size = 0
        parts[-1].append(e)
        size += cost
    return parts


def refine_chunks(agent: RefineAgent, session: str, sender: int,
                  budget_bytes: int = REFINE_BUDGET_BYTES) -> list[RefineChunk]:
    """What an agent publishes this period (its whole refine state, in chunks)."""
    prev_step, prev = -1, []
    if agent.previous is not None:
        prev_step, prev = agent.previous[0], encode_entries(agent.previous[1])
    current = [] if agent.done else encode_entries(agent.entries)
    chunks = []
    for part in _split(current, budget_bytes // 2):
        chunks.append(RefineChunk(session, sender, agent.step, tuple(part), prev_step, ()))
    for part in _split(prev, budget_bytes // 2):
        if part:
            chunks.append(RefineChunk(session, sender, agent.step, (), prev_step, tuple(part)))
    return chunks


def receive_chunk(agent: RefineAgent, chunk: RefineChunk) -> bool:
    """Merge what the chunk holds for the agent's current step; False if malformed."""
    p = agent.scorer.p
    cur = decode_entries(chunk.entries, p.n_agents, p.n_tasks)
    prev = decode_entries(chunk.previous, p.n_agents, p.n_tasks)
    if cur is None or prev is None:
        return False
    previous = (chunk.previous_step, prev) if chunk.previous_step >= 0 else None
    agent.receive((chunk.step, cur, previous))
    return True
