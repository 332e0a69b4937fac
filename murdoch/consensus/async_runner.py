"""CBBA and CBGA agents running asynchronously over the MURDOCH publish/subscribe bus.

Each agent is a `ConsensusNode` with its own transport endpoint. Every period it merges the
state messages that have arrived since its last period (releasing what it was outbid on),
quits stalled group tasks, builds its bundle, and publishes its whole state again on the
session's subject. Re-sending the whole state every period is what makes the allocators
tolerate lost, duplicated and reordered datagrams: whatever a lost message carried arrives
in the next one. A state larger than one datagram travels as several `ConsensusChunk`s, each
covering a range of tasks; the chunks of one state are merged against the same timestamps.

The scenario's communication graph is kept on the broadcast medium by ignoring messages from
agents that are not neighbours. Task quitting counts the agent's own periods.

`ConsensusSwarm` steps a set of nodes and decides convergence; `run_on_memory_bus` runs a whole
scenario on the in-memory bus with a manual clock (deterministic with a seeded `Random`).
"""

from __future__ import annotations

import logging
import random
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from murdoch.consensus.cbba import CbbaAgent
from murdoch.consensus.cbga import CbgaAgent, CbgaOptions
from murdoch.consensus.messages import ConsensusMessage
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import build_problem
from murdoch.consensus.sync_runner import AllocationResult, build_result, graph_diameter
from murdoch.transport import Transport
from murdoch.wire import Codec, Envelope

log = logging.getLogger(__name__)

SUBJECT_PREFIX = "consensus."
DATAGRAM_BUDGET_BYTES = 1300  # under the wire's 1400-byte limit, with room for the frame


@dataclass(frozen=True)
class ConsensusChunk:
    """Part of one agent's consensus state: its bids (and, on group tasks, the members'
    planned times) for tasks [first_task, first_task + task_count), and its timestamps
    (None = never heard from that agent)."""

    KIND: ClassVar[str] = "consensus-state"
    session: str
    sender: int
    time: float
    first_task: int
    task_count: int
    entries: tuple[tuple[int, int, float], ...]
    stamps: tuple[float | None, ...]
    starts: tuple[tuple[int, int, float], ...] = ()


CONSENSUS_CODEC = Codec([ConsensusChunk])


def _entry_size(entry: tuple[int, int, float]) -> int:
    return len(repr(entry[2])) + len(str(entry[0])) + len(str(entry[1])) + 5


def split_state(msg: ConsensusMessage, session: str, n_tasks: int,
                budget_bytes: int = DATAGRAM_BUDGET_BYTES) -> list[ConsensusChunk]:
    """Cut a state message into chunks of whole task rows that fit one datagram each."""
    stamps = tuple(None if not np.isfinite(t) else float(t) for t in msg.stamps)
    fixed = 160 + len(session) + sum(len(repr(t)) + 1 for t in stamps)
    rows: dict[int, list[tuple[int, int, float]]] = {}
    row_starts: dict[int, list[tuple[int, int, float]]] = {}
    for e in msg.entries:
        rows.setdefault(e[0], []).append(e)
    for e in msg.starts:
        row_starts.setdefault(e[0], []).append(e)
    chunks: list[ConsensusChunk] = []
    first, size = 0, fixed
    entries: list[tuple[int, int, float]] = []
    starts: list[tuple[int, int, float]] = []
    for j in range(n_tasks):
        row, row_t = rows.get(j, []), row_starts.get(j, [])
        row_size = sum(_entry_size(e) for e in row) + sum(_entry_size(e) for e in row_t)
        if (entries or starts) and size + row_size > budget_bytes:
            chunks.append(ConsensusChunk(session, msg.sender, msg.time, first, j - first,
                                         tuple(entries), stamps, tuple(starts)))
            first, size, entries, starts = j, fixed, [], []
        entries.extend(row)
        starts.extend(row_t)
        size += row_size
    chunks.append(ConsensusChunk(session, msg.sender, msg.time, first, n_tasks - first,
                                 tuple(entries), stamps, tuple(starts)))
    return chunks


def session_name(text: str) -> str:
    """A subject-safe session name derived from `text` (e.g. a scenario name)."""
    clean = re.sub(r"[^a-z0-9._:/-]", "-", text.lower()).strip("-._:/") or "session"
    return clean[:40]


def chunk_message(chunk: ConsensusChunk, kind: int) -> ConsensusMessage:
    stamps = tuple(-np.inf if t is None else t for t in chunk.stamps)
    return ConsensusMessage(kind, chunk.sender, chunk.time, chunk.entries, stamps,
                            chunk.starts)


Agent = CbbaAgent | CbgaAgent


class ConsensusNode:
    """One agent on one transport endpoint."""

    def __init__(self, agent: Agent, transport: Transport, session: str,
                 neighbours: frozenset[int] | None, clock: Callable[[], float]) -> None:
        self.agent = agent
        self.transport = transport
        self.session = session
        self.subject = SUBJECT_PREFIX + session
        self.neighbours = neighbours
        self.clock = clock
        self.iteration = 0
        self.ignored = 0
        self._inbox: list[ConsensusChunk] = []
        self._sub = transport.subscribe({self.subject}, callback=self._on_envelope)

    def _on_envelope(self, env: Envelope) -> None:
        msg = env.message
        if not isinstance(msg, ConsensusChunk) or msg.session != self.session:
            return
        self._inbox.append(msg)

    def _state(self) -> object:
        return self.agent.state_key()

    def step(self) -> bool:
        """One period: merge, release, quit, build, publish. True if the state changed."""
        a = self.agent
        self.iteration += 1
        now = self.clock()
        before = self._state()
        inbox, self._inbox = self._inbox, []
        groups: dict[tuple[int, float], list[ConsensusChunk]] = {}
        for c in inbox:
            if c.sender == a.index:
                continue
            if self.neighbours is not None and c.sender not in self.neighbours:
                self.ignored += 1
                continue
            groups.setdefault((c.sender, c.time), []).append(c)
        for chunks in groups.values():
            for c in chunks:
                a.receive(chunk_message(c, a.kind), now, (c.first_task,
                                                          c.first_task + c.task_count),
                          merge=False)
            a.merge_stamps(chunk_message(chunks[-1], a.kind), now)
        a.release_outbid()
        if isinstance(a, CbgaAgent):
            a.refresh_times()
            a.quit_stalled(float(self.iteration))
        a.build_bundle(float(self.iteration))
        for chunk in split_state(a.message(now), self.session, a.problem.n_tasks):
            self.transport.publish({self.subject}, chunk)
        return self._state() != before

    def pending_quit(self) -> bool:
        return isinstance(self.agent, CbgaAgent) and np.isfinite(self.agent.next_quit_time())

    def close(self) -> None:
        self._sub.close()


@dataclass(frozen=True)
class SwarmOutcome:
    result: AllocationResult
    periods: int
    datagrams: int
    bytes: int


class ConsensusSwarm:
    """Steps nodes period by period until nothing has changed for `quiet_periods`."""

    def __init__(self, scenario: Scenario, algorithm: str, nodes: Sequence[ConsensusNode],
                 deliver: Callable[[], object], advance: Callable[[], None]) -> None:
        self.scenario = scenario
        self.algorithm = algorithm
        self.nodes = list(nodes)
        self.deliver = deliver
        self.advance = advance

    def run(self, max_periods: int = 2000, quiet_periods: int | None = None) -> SwarmOutcome:
        neighbours = self.scenario.neighbours()
        active = [True] * len(self.nodes)
        quiet_needed = quiet_periods or 3 * (graph_diameter(neighbours, active) + 2)
        quiet = 0
        last_change = 0
        period = 0
        while period < max_periods:
            period += 1
            self.deliver()
            changed = False
            for node in self.nodes:
                changed |= node.step()
            if changed:
                quiet = 0
                last_change = period
            else:
                quiet += 1
            if quiet >= quiet_needed and not any(n.pending_quit() for n in self.nodes):
                break
            self.advance()
        converged = quiet >= quiet_needed
        datagrams = sum(n.transport.counters.sent(ConsensusChunk.KIND) for n in self.nodes)
        nbytes = sum(c.sent_bytes for n in self.nodes
                     for k, c in n.transport.counters.kinds.items()
                     if k == ConsensusChunk.KIND)
        problem = self.nodes[0].agent.problem
        paths = [list(n.agent.path) for n in self.nodes]
        views = [n.agent.winners_view() for n in self.nodes]
        result = build_result(self.algorithm, problem, paths, views, active, neighbours,
                              converged, last_change, datagrams, nbytes, period)
        return SwarmOutcome(result, period, datagrams, nbytes)


class ManualClock:
    """A clock that moves only when told to (for runs on the in-memory bus)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.now_s = start_s

    def __call__(self) -> float:
        return self.now_s

    def advance(self, dt_s: float) -> None:
        self.now_s += dt_s


def make_agent(problem_scenario: Scenario, algorithm: str, index: int,
               options: CbgaOptions | None) -> Agent:
    problem = build_problem(problem_scenario)
    if algorithm == "cbba":
        if (problem.required != 1).any():
            raise ValueError("CBBA handles single-agent tasks only; use CBGA for group tasks")
        return CbbaAgent(problem, index)
    if algorithm == "cbga":
        return CbgaAgent(problem, index, options)
    raise ValueError(f"unknown algorithm {algorithm!r} (expected 'cbba' or 'cbga')")


def make_nodes(scenario: Scenario, algorithm: str, options: CbgaOptions | None,
               transports: Sequence[Transport], clock: Callable[[], float],
               session: str) -> list[ConsensusNode]:
    nbrs = scenario.neighbours()
    return [ConsensusNode(make_agent(scenario, algorithm, i, options), t, session,
                          frozenset(nbrs[i]), clock)
            for i, t in enumerate(transports)]


def run_on_memory_bus(scenario: Scenario, algorithm: str, rng: random.Random,
                      loss: float = 0.0, options: CbgaOptions | None = None,
                      period_s: float = 0.05, max_delay_s: float = 0.0,
                      max_periods: int = 2000, quiet_periods: int | None = None
                      ) -> SwarmOutcome:
    """Run a scenario on a fresh in-memory bus with seeded loss (and delay up to
    `max_delay_s`, which reorders datagrams)."""
    from murdoch.memory_bus import MemoryBus, NetworkFaults

    clock = ManualClock()
    bus = MemoryBus(clock, rng, NetworkFaults(loss=loss, delay_s=(0.0, max_delay_s)))
    transports = [bus.endpoint(a.id, CONSENSUS_CODEC) for a in scenario.agents]
    nodes = make_nodes(scenario, algorithm, options, transports, clock,
                       session_name(scenario.name))

    def advance() -> None:
        clock.advance(period_s)

    swarm = ConsensusSwarm(scenario, algorithm, nodes, bus.deliver_due, advance)
    try:
        return swarm.run(max_periods, quiet_periods)
    finally:
        for n in nodes:
            n.close()
        for t in transports:
            t.close()
