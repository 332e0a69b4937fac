"""The improvement phase of `--refine`: pairwise exchanges agreed through consensus.

After CBBA or CBGA has converged, every agent knows the winners of every task but only its
own path. The phase runs in numbered steps; each agent floods one entry per step to its
neighbours and acts when it holds the entries of all agents for that step:

- **step 0**: the entry is the agent's own path. Holding every path, each agent knows the
  agreed plan (identical on every agent).
- **opening** (instead of step 0, when the plain run converged with every agent holding the
  same winners): every agent derives the same guessed plan from the winners alone
  (`refine_plan.guess_plan`: each agent's tasks in their best agent-alone order) and sends,
  in one entry, its own path only where it differs from the guess (without group tasks an
  agent whose guessed path scores at least as well adopts it) and its proposal on the
  guessed plan. The agreed plan is the guess with the paths sent in place; the proposals
  are selected on it like any step's. This saves the paths' round.
- **step t >= 1**: the entry is the agent's proposal: the best change of the plan that it
  can make from its own side, or nothing. Moves are computed by the agent alone, on its
  copy of the plan: take a task from another agent or from the unassigned ones (a group
  task: replace one member, or join a group that is short), swap one of its tasks for
  another agent's, move one of its own tasks to a better place in its path, fill a
  group task that has no complete group (itself and the partners that gain most), move a
  whole group task to a new group of itself and such partners (regroup), or re-plan
  itself and one other agent (`pair_replan.py`).
  A proposal carries the new paths of the agents it changes and the gain in the total
  score (`evaluate_plan`) it brings.
- Holding all proposals of step t, every agent applies the same selection: proposals by
  gain (equal gains ordered by a seeded ranking of the agents, not by their index),
  each accepted when it touches none of the agents already changed in this step, keeps
  the plan conflict-free with every task completing, and raises the total score. The
  agents therefore hold the same new plan, and the next step begins. A step in which no
  agent proposes anything ends the phase on every agent.

The phase only raises the total score, never leaves a task with more agents than it needs
and never keeps a task that does not complete. An agent that has all entries of a step
and moves on sends, once, the complete entries of the step it left, so that a neighbour
still missing some completes it with that message (neighbours are at most one step apart).

Communication: one message per link per round; the encoding counted in bytes is the
consensus header (15 bytes), then per path entry 4 bytes (agent, length) plus 2 per task,
per proposal 12 bytes (agent, gain, number of paths) plus its paths. Rounds per step are at
most the graph diameter; a full graph needs one round per step.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import cast

import numpy as np

from murdoch.consensus.allocation_result import AllocationResult, build_result, graph_diameter
from murdoch.consensus.pair_replan import PairReplan
from murdoch.consensus.refine_moves import MoveSearch
from murdoch.consensus.refine_plan import (
    GAIN_TOL,
    Plan,
    PlanScorer,
    Proposal,
    canonical_plan,
    guess_plan,
    with_changes,
)
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import Problem, build_problem, evaluate_plan

__all__ = ["MoveSearch", "Opening", "Plan", "PlanScorer", "Proposal", "RefineAgent",
           "RefineOptions", "RefineOutcome", "canonical_plan", "complete_graph", "guess_plan",
           "make_refine_agent", "refine_allocation", "run_refinement", "seeded_rank",
           "select", "step_limit", "strongly_connected"]
_HEADER_BYTES = 15

# what an agent sends: its step, the entries it holds for that step, and (once) the complete
# entries of the step it left
RefineMessage = tuple[int, dict[int, object], tuple[int, dict[int, object]] | None]
_GAIN_TOL = GAIN_TOL


@dataclass(frozen=True)
class RefineOptions:
    """`seed` orders equal proposals; `max_steps` bounds the proposal steps; `pairs` adds
    the two-agent re-plan (`pair_replan.py`) to each agent's moves. `budget` bounds the
    phase's rounds by that fraction of the plain run's communication rounds (`comm_steps`,
    which every agent of a synchronous run knows), but allows at least `min_rounds`; None
    lifts the bound (then only `max_steps` applies). `opening` replaces the paths step by
    the opening (paths sent only where they differ from the plan guessed from the agreed
    winners, with the first proposals). `regroup` adds the move of a whole group task to a
    new group (the proposer and the partners that gain most; old members may stay)."""

    seed: int = 0
    max_steps: int = 50
    pairs: bool = True
    budget: float | None = 0.5
    min_rounds: int = 1
    opening: bool = True
    regroup: bool = True


def select(scorer: PlanScorer, plan: Plan, proposals: Sequence[Proposal], rank: Sequence[int]
           ) -> tuple[Plan, int]:
    """The plan after the step's proposals (same on every agent): (new plan, moves)."""
    order = sorted(proposals, key=lambda pr: (-pr.gain, rank[pr.agent]))
    current = plan
    value = scorer.score(plan)
    touched: set[int] = set()
    moves = 0
    for pr in order:
        agents = {k for k, _ in pr.paths}
        if agents & touched:
            continue
        trial = with_changes(current, dict(pr.paths))
        v = scorer.score(trial)
        if v > value + _GAIN_TOL * max(1.0, abs(value)):
            current, value = trial, v
            touched |= agents
            moves += 1
    return current, moves


# ----------------------------------------------------------------------------- one agent


@dataclass(frozen=True)
class Opening:
    """An agent's entry of the opening step: its path where it differs from the guessed
    plan (None: the guess is its path) and its proposal on the guessed plan."""

    path: tuple[int, ...] | None
    proposal: Proposal | None

    def size(self) -> int:
        path = 2 if self.path is None else 4 + 2 * len(self.path)
        return path + (2 if self.proposal is None else self.proposal.size())


@dataclass
class RefineAgent:
    """One agent's part of the improvement phase (state and its message handling)."""

    scorer: PlanScorer
    index: int
    rank: Sequence[int]
    own_path: tuple[int, ...]
    max_steps: int = 50
    step: int = 0
    plan: Plan | None = None
    done: bool = False
    moves: int = 0
    entries: dict[int, object] = field(default_factory=dict)
    previous: tuple[int, dict[int, object]] | None = None
    pair: PairReplan | None = None
    regroup: bool = True
    resend: bool = True  # False when every agent hears every other directly
    guess: Plan | None = None  # the plan derived from the agreed winners (opening step)

    def __post_init__(self) -> None:
        if self.guess is None:
            self.entries = {self.index: self.own_path}
            return
        # the opening: the paths step and the first proposals in one
        i, own, guessed = self.index, self.own_path, self.guess[self.index]
        path: tuple[int, ...] | None = own
        if own == guessed or (not self.scorer.groups and self.scorer.path_value(i, guessed)
                              >= self.scorer.path_value(i, own)):
            path = None  # the guess is (or is adopted as) this agent's path
        local = canonical_plan(self.scorer.p, with_changes(self.guess, {i: path or guessed}))
        self.step = 1
        self.entries = {i: Opening(path, self._search(local))}

    def _search(self, plan: Plan) -> Proposal | None:
        return MoveSearch(self.scorer, self.index, self.pair, self.regroup).best(plan)

    def message(self) -> RefineMessage:
        prev, self.previous = self.previous, None
        return self.step, dict(self.entries), prev

    def message_size(self, msg: RefineMessage) -> int:
        step, entries, prev = msg
        size = _HEADER_BYTES + _entries_size(step, entries)
        if prev is not None:
            size += _entries_size(*prev)
        return size

    def receive(self, msg: RefineMessage) -> None:
        step, entries, prev = msg
        if prev is not None and prev[0] == self.step:
            self._merge(prev[1])
        if step == self.step:
            self._merge(entries)

    def _merge(self, entries: dict[int, object]) -> None:
        for k, e in entries.items():
            self.entries.setdefault(k, e)

    def _keep_previous(self) -> None:
        """Keep the completed step to send once more (for neighbours still missing
        entries of it); on a complete graph every agent completes a step in the same round."""
        self.previous = (self.step, dict(self.entries)) if self.resend else None

    def advance(self) -> bool:
        """Act on a complete step; True when this agent moved to the next step."""
        n = self.scorer.p.n_agents
        if self.done or len(self.entries) < n:
            return False
        if self.step == 0:
            paths = [tuple(cast("Iterable[int]", self.entries[k])) for k in range(n)]
            self.plan = canonical_plan(self.scorer.p, paths)
            proposals: list[Proposal] = []
        elif self.step == 1 and self.guess is not None:
            opening = cast("dict[int, Opening]", self.entries)
            guessed = [opening[k].path for k in range(n)]
            self.plan = canonical_plan(self.scorer.p, [self.guess[k] if q is None else q
                                                       for k, q in enumerate(guessed)])
            proposals = [e.proposal for e in opening.values() if e.proposal is not None]
        else:
            proposals = [e for e in self.entries.values() if isinstance(e, Proposal)]
        assert self.plan is not None
        if self.step > 0:
            if not proposals:
                self.done = True
                self._keep_previous()
                self.entries = {}
                return True
            else:
                self.plan, moved = select(self.scorer, self.plan, proposals, self.rank)
                self.moves += moved
        self._keep_previous()
        self.step += 1
        if self.step > self.max_steps:
            self.done = True
            self.entries = {}
            return True
        self.entries = {self.index: self._search(self.plan)}
        return True


def make_refine_agent(scorer: PlanScorer, index: int, rank: Sequence[int],
                      own_path: tuple[int, ...], options: RefineOptions,
                      max_steps: int | None = None, resend: bool = True,
                      guess: Plan | None = None) -> RefineAgent:
    """Agent `index`'s part of the phase, starting from its own (canonical) path; with
    `guess` (the plan derived from the agreed winners) it opens with its first proposal."""
    pair = PairReplan(scorer, index) if options.pairs else None
    steps = options.max_steps if max_steps is None else max_steps
    return RefineAgent(scorer, index, rank, own_path, steps, pair=pair,
                       regroup=options.regroup, resend=resend, guess=guess)


def complete_graph(neighbours: Sequence[Sequence[int]]) -> bool:
    """Whether every agent hears every other directly."""
    n = len(neighbours)
    return all(set(ks) >= set(range(n)) - {i} for i, ks in enumerate(neighbours))


def step_limit(options: RefineOptions, plain_rounds: int, diameter: int,
               opening: bool = False) -> int:
    """Proposal steps allowed by the round budget: a step takes at most `diameter` rounds,
    and the paths (step 0) take one step unless the phase opens with proposals."""
    if options.budget is None:
        return options.max_steps
    rounds = max(options.min_rounds, math.floor(options.budget * plain_rounds))
    return max(1, min(options.max_steps, rounds // max(1, diameter) - (not opening)))


def _entries_size(step: int, entries: dict[int, object]) -> int:
    size = 4
    for e in entries.values():
        if isinstance(e, Proposal | Opening):
            size += e.size()
        elif isinstance(e, tuple):
            size += 4 + 2 * len(e)
        else:
            size += 2  # "no proposal"
    return size


def seeded_rank(n: int, seed: int) -> list[int]:
    """Position of each agent in the seeded order that settles equal proposals."""
    perm = np.random.default_rng(seed).permutation(n)
    rank = [0] * n
    for pos, k in enumerate(perm.tolist()):
        rank[k] = pos
    return rank


@dataclass(frozen=True)
class RefineOutcome:
    plan: Plan
    rounds: int
    messages: int
    bytes: int
    steps: int
    moves: int
    converged: bool


def run_refinement(p: Problem, paths: Sequence[Sequence[int]],
                   neighbours: Sequence[Sequence[int]], options: RefineOptions,
                   max_rounds: int = 1000, max_steps: int | None = None,
                   agreed: bool = True) -> RefineOutcome:
    """Run the improvement phase in synchronous rounds over the communication graph (every
    agent sends to its out-neighbours each round until it has finished). `agreed`: every
    agent holds the same winners (which tasks each agent has), so with `options.opening`
    every agent derives the same guessed plan from them."""
    n = p.n_agents
    scorer = PlanScorer(p)
    start = canonical_plan(p, paths)
    rank = seeded_rank(n, options.seed)
    resend = not complete_graph(neighbours)
    guess = guess_plan(scorer, paths) if options.opening and agreed else None
    agents = [make_refine_agent(scorer, i, rank, start[i], options, max_steps, resend, guess)
              for i in range(n)]
    rounds = messages = nbytes = 0
    while not all(a.done and a.previous is None for a in agents) and rounds < max_rounds:
        rounds += 1
        sent: list[RefineMessage | None] = []
        for a in agents:
            if a.done and a.previous is None:
                sent.append(None)
                continue
            sent.append(a.message())
        for i, ks in enumerate(neighbours):
            for k in ks:
                msg = sent[k]
                if msg is None:
                    continue
                messages += 1
                nbytes += agents[k].message_size(msg)
                agents[i].receive(msg)
        for a in agents:
            a.advance()
    plans = {a.plan for a in agents}
    converged = all(a.done for a in agents) and len(plans) == 1
    final = agents[0].plan if agents[0].plan is not None else start
    return RefineOutcome(final, rounds, messages, nbytes, max(a.step for a in agents),
                         agents[0].moves, converged)


def strongly_connected(neighbours: Sequence[Sequence[int]]) -> bool:
    """Whether every agent hears, directly or through others, from every other."""
    n = len(neighbours)
    for src in range(n):
        seen = {src}
        stack = [src]
        while stack:
            a = stack.pop()
            for b in range(n):
                if b not in seen and a in neighbours[b]:
                    seen.add(b)
                    stack.append(b)
        if len(seen) < n:
            return False
    return True


def refine_allocation(scenario: Scenario, plain: AllocationResult,
                      options: RefineOptions | None = None) -> AllocationResult:
    """`plain` (a converged CBBA or CBGA run on `scenario`) followed by the improvement
    phase; communication is the sum of both, `extra["refine"]` holds the phase's share."""
    options = options or RefineOptions()
    p = build_problem(scenario)
    neighbours = scenario.neighbours()
    extra = dict(plain.extra)
    engine = extra.get("engine", "agents")
    note = ("the improvement phase (--refine) runs in Python on top of the compiled engine's "
            "result" if engine == "compiled" else
            "the improvement phase (--refine) runs in Python after the agents' run")
    extra["engine_note"] = f"{extra['engine_note']}; {note}" if extra.get("engine_note") else note
    ids = {t.id: j for j, t in enumerate(scenario.tasks)}
    paths = [[ids[t] for t in plain.assignment.get(a.id, [])] for a in scenario.agents]
    if not strongly_connected(neighbours):
        extra["refine"] = {"skipped": "the communication graph is not strongly connected: "
                                      "agents cannot agree on one plan"}
        return replace(plain, extra=extra)
    diameter = graph_diameter(neighbours, [True] * p.n_agents)
    agreed = plain.converged and plain.agreed
    limit = step_limit(options, plain.comm_steps, diameter, options.opening and agreed)
    out = run_refinement(p, paths, neighbours, options, max_steps=limit, agreed=agreed)
    plan = [list(q) for q in out.plan]
    views = [[frozenset(g) for g in evaluate_plan(p, plan).group]] * p.n_agents
    res = build_result(plain.algorithm, p, plan, views, [True] * p.n_agents, neighbours,
                       plain.converged and out.converged, plain.comm_steps + out.rounds,
                       plain.messages + out.messages, plain.bytes + out.bytes,
                       plain.rounds + out.rounds,
                       # the phase's sends each carry new paths or proposals; it has
                       # one encoding, so its bytes count in both forms
                       plain.pairwise_steps + out.messages, plain.bytes_dense + out.bytes)
    extra["refine"] = {"plain_score": plain.total_score, "rounds": out.rounds,
                       "messages": out.messages, "bytes": out.bytes, "steps": out.steps,
                       "moves": out.moves, "converged": out.converged}
    return replace(res, extra=extra)
