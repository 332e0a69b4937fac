"""Synchronous rounds of CBBA or CBGA over a scenario's communication graph.

A round: every agent (quits stalled group tasks, then) builds its bundle; every agent sends its
state to each neighbour; every agent merges its neighbours' messages in index order; every
agent releases what it was outbid on (and, in CBGA, re-plans against its partners' times).
Timestamps are round numbers.

Measured: **comm_steps** = the last round in which any agent's bids (y, z, or CBGA's X and
its group members' planned times) or bundle changed; **messages** = agent-to-neighbour
transmissions in rounds 1..comm_steps; **bytes** = the encoded size (`messages.encode`) of
those transmissions; **pairwise_steps** = those transmissions whose allocation data (the
message's entries and members' times) differ from what the sender sent the round before
(the CBGA paper's count of steps); **bytes_dense** = the same messages in the dense matrix
form (`messages.dense_encoded_size`). The run stops once nothing has changed for (graph
diameter + 1) rounds and no task-quitting timer is pending, or at
`max_rounds` (then `converged` is false).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, Literal

from murdoch.consensus.allocation_result import (
    AllocationResult,
    build_result,
    graph_diameter,
)
from murdoch.consensus.cbba import CbbaAgent
from murdoch.consensus.cbga import CbgaAgent, CbgaOptions
from murdoch.consensus.conflict import NONE
from murdoch.consensus.messages import encoded_size
from murdoch.consensus.scenario import Scenario, Task
from murdoch.consensus.scoring import build_problem

Algorithm = Literal["cbba", "cbga"]

log = logging.getLogger(__name__)


class SyncRunner:
    """Runs one allocator in synchronous rounds; supports adding tasks and removing agents."""

    def __init__(self, scenario: Scenario, algorithm: Algorithm = "cbba",
                 options: CbgaOptions | None = None, max_rounds: int = 1000) -> None:
        if algorithm not in ("cbba", "cbga"):
            raise ValueError(f"unknown algorithm {algorithm!r} (expected 'cbba' or 'cbga')")
        if algorithm == "cbba" and any(t.agents_required != 1 for t in scenario.tasks):
            raise ValueError("CBBA handles single-agent tasks only; use CBGA for group tasks")
        self.algorithm = algorithm
        self.options = options or CbgaOptions()
        self.max_rounds = max_rounds
        self.scenario = scenario
        self.problem = build_problem(scenario)
        n = self.problem.n_agents
        self.active = [True] * n
        self.round = 0
        self.last_change = 0
        self.quiet = 0
        # (messages, bytes, sends carrying changed data) per round
        self.per_round: list[tuple[int, int, int]] = []
        # what each agent sent last round (`sent_data`; nothing before round 1)
        self._last_sent: list[object] = [((), ())] * n
        self.agents: list[CbbaAgent | CbgaAgent] = (
            [CbbaAgent(self.problem, i) for i in range(n)] if algorithm == "cbba"
            else [CbgaAgent(self.problem, i, self.options) for i in range(n)])
        self._set_graph(scenario)

    def _set_graph(self, scenario: Scenario) -> None:
        nbrs = scenario.neighbours()
        self.neighbours = tuple(tuple(k for k in ks if self.active[k]) if self.active[i] else ()
                                for i, ks in enumerate(nbrs))
        self.out_degree = [0] * len(nbrs)
        for ks in self.neighbours:
            for k in ks:
                self.out_degree[k] += 1
        self.diameter = graph_diameter(self.neighbours, self.active)

    # -- one round ----------------------------------------------------------------------
    def step(self) -> bool:
        self.round += 1
        now = float(self.round)
        before = self._signature()
        for a in self.agents:
            if isinstance(a, CbgaAgent):
                a.quit_stalled(now)
        for a in self.agents:
            a.build_bundle(now)
        self._count_messages()
        self._consensus(now)
        for a in self.agents:
            a.release_outbid()
            if isinstance(a, CbgaAgent):
                a.refresh_times()
        changed = self._signature() != before
        if changed:
            self.last_change = self.round
            self.quiet = 0
        else:
            self.quiet += 1
        return changed

    def _signature(self) -> list[object]:
        return [a.state_key() for a in self.agents]

    def _count_messages(self) -> None:
        msgs = 0
        nbytes = 0
        pairs = 0
        n = self.problem.n_agents
        for k, a in enumerate(self.agents):
            d = self.out_degree[k]
            if not d or not self.active[k]:
                continue
            starts = 0
            if isinstance(a, CbbaAgent):
                entries = len(a.z) - a.z.count(NONE)
            else:
                entries, starts = a.sent_counts()
            msgs += d
            nbytes += d * encoded_size(entries, n, starts)
            data = a.sent_data()
            if data != self._last_sent[k]:
                pairs += d
            self._last_sent[k] = data
        self.per_round.append((msgs, nbytes, pairs))

    def _consensus(self, now: float) -> None:
        """Every agent receives what each of its neighbours sends this round.

        What is sent is taken from every agent before any receives (copies of its lists,
        with its own stamp set to `now`). CBBA's lists are replaced, never shared; merging
        CBGA's replaces an agent's rows (never changes one in place) and never keeps a
        sender's row, so a copy of the row lists holds the rows as they were sent."""
        sent: list[tuple[list[Any], list[Any], list[float]]] = []
        for k, a in enumerate(self.agents):
            s_k = list(a.s)
            s_k[k] = now
            if isinstance(a, CbbaAgent):
                sent.append((list(a.y), list(a.z), s_k))
            else:
                sent.append((list(a.x), list(a.t), s_k))
        for i, ks in enumerate(self.neighbours):
            agent = self.agents[i]
            receive = agent.apply if isinstance(agent, CbbaAgent) else agent.receive_rows
            for k in ks:
                first, second, s_k = sent[k]
                receive(k, first, second, s_k, now)

    # -- running ------------------------------------------------------------------------
    def pending_quit(self) -> bool:
        return any(isinstance(a, CbgaAgent) and a.next_quit_time() < math.inf
                   for a in self.agents)

    def done(self) -> bool:
        return self.quiet >= self.diameter + 1 and not self.pending_quit()

    def run(self) -> AllocationResult:
        start_round = self.round
        while not self.done() and self.round - start_round < self.max_rounds:
            self.step()
        return self.result()

    def result(self) -> AllocationResult:
        steps = self.last_change
        msgs = sum(r[0] for r in self.per_round[:steps])
        nbytes = sum(r[1] for r in self.per_round[:steps])
        pairs = sum(r[2] for r in self.per_round[:steps])
        paths = [list(a.path) if self.active[i] else [] for i, a in enumerate(self.agents)]
        views = [a.winners_view() for a in self.agents]
        return build_result(self.algorithm, self.problem, paths, views, self.active,
                            self.neighbours, self.done(), steps, msgs, nbytes, self.round,
                            pairs)

    # -- dynamic changes ----------------------------------------------------------------
    def add_tasks(self, tasks: Sequence[Task]) -> None:
        """New tasks become known to every agent at once; bids resume next round."""
        if self.algorithm == "cbba" and any(t.agents_required != 1 for t in tasks):
            raise ValueError("CBBA handles single-agent tasks only")
        self.scenario = self.scenario.with_tasks(tasks)
        problem = build_problem(self.scenario)
        self.problem = problem
        for a in self.agents:
            a.add_tasks(problem)
        self.quiet = 0

    def remove_agent(self, agent_id: str) -> None:
        """An agent leaves: links to it are cut and the others drop its bids."""
        ids = [a.id for a in self.scenario.agents]
        gone = ids.index(agent_id)
        self.active[gone] = False
        agent = self.agents[gone]
        agent.active = False
        agent.bundle, agent.path = [], []
        for i, a in enumerate(self.agents):
            if i != gone:
                a.forget_agent(gone)
        self.scenario = self.scenario.without_agent_edges(agent_id)
        self._set_graph(self.scenario)
        self.quiet = 0


def allocate(scenario: Scenario, algorithm: Algorithm = "cbba",
             options: CbgaOptions | None = None, max_rounds: int = 1000,
             compiled: bool = True, refine: bool | Any = False) -> AllocationResult:
    """Run an allocator to convergence in synchronous rounds.

    With `refine` (True or a `refine.RefineOptions`) the converged run is followed by the
    improvement phase of `refine.py` (pairwise exchanges agreed through consensus);
    ``extra["refine"]`` reports its share of the communication. The default runs the
    papers' algorithms unchanged.

    CBBA and CBGA each run as one compiled function (`cbba_fast`, `cbga_fast`) when
    `compiled` is true and the scenario allows it, with the same results as the agents;
    otherwise the agents of `SyncRunner` run. ``result.extra["engine"]`` says which ran
    ("compiled" or "agents") and, when the compiled run was requested but could not take
    the scenario, ``extra["engine_note"]`` says why."""
    if refine:
        from murdoch.consensus.refine import RefineOptions, refine_allocation

        plain = allocate(scenario, algorithm, options, max_rounds, compiled)
        opts = refine if isinstance(refine, RefineOptions) else RefineOptions()
        return refine_allocation(scenario, plain, opts)
    note = "not requested"
    if compiled and algorithm == "cbba":
        from murdoch.consensus.cbba_fast import allocate_compiled, compiled_cbba_unsupported

        reason = compiled_cbba_unsupported(scenario)
        if reason is None:
            return allocate_compiled(scenario, max_rounds)
        note = reason
        log.debug("CBBA on %s runs on the agents: %s", scenario.name, reason)
    elif compiled and algorithm == "cbga":
        from murdoch.consensus.cbga_fast import (
            allocate_compiled_cbga,
            compiled_cbga_unsupported,
        )

        reason = compiled_cbga_unsupported(scenario, options)
        if reason is None:
            return allocate_compiled_cbga(scenario, options, max_rounds)
        note = reason
        log.debug("CBGA on %s runs on the agents: %s", scenario.name, reason)
    result = SyncRunner(scenario, algorithm, options, max_rounds).run()
    return replace(result, extra={"engine": "agents", "engine_note": note})
