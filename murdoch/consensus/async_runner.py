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

from murdoch.consensus.allocation_result import AllocationResult, build_result, graph_diameter
from murdoch.consensus.async_refine import RefineChunk, receive_chunk, refine_chunks
from murdoch.consensus.cbba import CbbaAgent
from murdoch.consensus.cbga import CbgaAgent, CbgaOptions
from murdoch.consensus.messages import ConsensusMessage
from murdoch.consensus.refine import (
    PlanScorer,
    RefineAgent,
    RefineOptions,
    make_refine_agent,
    seeded_rank,
)
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import build_problem, evaluate_plan
from murdoch.manual_clock import ManualClock
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


CONSENSUS_CODEC = Codec([ConsensusChunk, RefineChunk])
_KINDS = (ConsensusChunk.KIND, RefineChunk.KIND)


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
    """One agent on one transport endpoint.

    With `refine`, once the node's consensus state has not changed for `settle_periods`
    of its periods (and no quit is pending) it starts the improvement phase
    (`async_refine.py`) from its path and publishes only refine state from then on."""

    def __init__(self, agent: Agent, transport: Transport, session: str,
                 neighbours: frozenset[int] | None, clock: Callable[[], float],
                 refine: RefineOptions | None = None, settle_periods: int = 9) -> None:
        self.agent = agent
        self.refine = refine
        self.settle_periods = settle_periods
        self.refiner: RefineAgent | None = None
        self.refused = 0
        self._quiet = 0
        self._refine_inbox: list[RefineChunk] = []
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
        if isinstance(msg, RefineChunk) and msg.session == self.session:
            if self.refine is not None:
                self._refine_inbox.append(msg)
            return
        if not isinstance(msg, ConsensusChunk) or msg.session != self.session:
            return
        self._inbox.append(msg)

    def _state(self) -> object:
        return self.agent.state_key()

    def step(self) -> bool:
        """One period: merge, release, quit, build, publish (or, once refining, one period
        of the improvement phase). True if the state changed."""
        if self.refiner is not None:
            return self._refine_step()
        changed = self._consensus_step()
        self._quiet = 0 if changed else self._quiet + 1
        if (self.refine is not None and self._quiet >= self.settle_periods
                and not self.pending_quit()):
            self._start_refine()
            return True
        return changed

    def _start_refine(self) -> None:
        assert self.refine is not None
        a = self.agent
        n = a.problem.n_agents
        rank = seeded_rank(n, self.refine.seed)
        self.refiner = make_refine_agent(PlanScorer(a.problem), a.index, rank,
                                         tuple(a.path), self.refine)
        self._refine_inbox.clear()  # older chunks: their senders send them again
        self._publish_refine()

    def _publish_refine(self) -> None:
        assert self.refiner is not None
        for chunk in refine_chunks(self.refiner, self.session, self.agent.index):
            self.transport.publish({self.subject}, chunk)

    def _refine_step(self) -> bool:
        r = self.refiner
        assert r is not None
        self.iteration += 1
        self._inbox.clear()
        inbox, self._refine_inbox = self._refine_inbox, []
        before = (r.step, r.done, r.plan)
        for c in inbox:
            if c.sender == self.agent.index:
                continue
            if self.neighbours is not None and c.sender not in self.neighbours:
                self.ignored += 1
                continue
            if not receive_chunk(r, c):
                self.refused += 1
                if self.refused == 1 or self.refused % 100 == 0:
                    log.warning("consensus %s: refused %d malformed refine chunk(s), last "
                                "from agent %s", self.session, self.refused, c.sender)
        r.advance()
        self._publish_refine()
        return (r.step, r.done, r.plan) != before

    def pending_refine(self) -> bool:
        return self.refine is not None and (self.refiner is None or not self.refiner.done)

    def final_path(self) -> list[int]:
        """The node's path: the refined plan's when the phase has finished."""
        r = self.refiner
        if r is not None and r.done and r.plan is not None:
            return list(r.plan[self.agent.index])
        return list(self.agent.path)

    def winners_view(self) -> list[frozenset[int]]:
        r = self.refiner
        if r is not None and r.done and r.plan is not None:
            ev = evaluate_plan(self.agent.problem, [list(q) for q in r.plan])
            return [frozenset(g) for g in ev.group]
        return self.agent.winners_view()

    def _consensus_step(self) -> bool:
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
            if quiet >= quiet_needed and not any(n.pending_quit() or n.pending_refine()
                                                 for n in self.nodes):
                break
            self.advance()
        converged = quiet >= quiet_needed and not any(n.pending_refine() for n in self.nodes)
        datagrams = sum(n.transport.counters.sent(k) for n in self.nodes for k in _KINDS)
        nbytes = sum(c.sent_bytes for n in self.nodes
                     for k, c in n.transport.counters.kinds.items() if k in _KINDS)
        problem = self.nodes[0].agent.problem
        paths = [n.final_path() for n in self.nodes]
        views = [n.winners_view() for n in self.nodes]
        result = build_result(self.algorithm, problem, paths, views, active, neighbours,
                              converged, last_change, datagrams, nbytes, period,
                              # (measured in synchronous runs only)
                              pairwise_steps=0, bytes_dense=0)
        return SwarmOutcome(result, period, datagrams, nbytes)


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


def settle_periods_for(scenario: Scenario) -> int:
    """Quiet periods after which a node takes its consensus state as settled (the same
    number `ConsensusSwarm` waits for by default)."""
    nbrs = scenario.neighbours()
    return 3 * (graph_diameter(nbrs, [True] * len(nbrs)) + 2)


def make_nodes(scenario: Scenario, algorithm: str, options: CbgaOptions | None,
               transports: Sequence[Transport], clock: Callable[[], float],
               session: str, refine: RefineOptions | None = None) -> list[ConsensusNode]:
    """One node per agent; with `refine` each runs the improvement phase once settled."""
    nbrs = scenario.neighbours()
    settle = settle_periods_for(scenario)
    return [ConsensusNode(make_agent(scenario, algorithm, i, options), t, session,
                          frozenset(nbrs[i]), clock, refine, settle)
            for i, t in enumerate(transports)]


def run_on_memory_bus(scenario: Scenario, algorithm: str, rng: random.Random,
                      loss: float = 0.0, options: CbgaOptions | None = None,
                      period_s: float = 0.05, max_delay_s: float = 0.0,
                      max_periods: int = 2000, quiet_periods: int | None = None,
                      refine: RefineOptions | None = None) -> SwarmOutcome:
    """Run a scenario on a fresh in-memory bus with seeded loss (and delay up to
    `max_delay_s`, which reorders datagrams); with `refine`, followed by the improvement
    phase."""
    from murdoch.memory_bus import MemoryBus, NetworkFaults

    clock = ManualClock()
    bus = MemoryBus(clock, rng, NetworkFaults(loss=loss, delay_s=(0.0, max_delay_s)))
    transports = [bus.endpoint(a.id, CONSENSUS_CODEC) for a in scenario.agents]
    nodes = make_nodes(scenario, algorithm, options, transports, clock,
                       session_name(scenario.name), refine)

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
