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

from murdoch.consensus.pair_replan import PairReplan
from murdoch.consensus.refine_plan import (
    GAIN_TOL,
    Plan,
    PlanScorer,
    Proposal,
    canonical_plan,
    guess_plan,
    insertions,
    with_changes,
    without,
)
from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import Problem, build_problem, evaluate_plan
from murdoch.consensus.sync_runner import AllocationResult, build_result, graph_diameter

__all__ = ["Opening", "Plan", "PlanScorer", "Proposal", "RefineAgent", "RefineOptions",
           "RefineOutcome", "canonical_plan", "complete_graph", "guess_plan",
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


class MoveSearch:
    """One agent's search for its best proposal on the agreed plan."""

    def __init__(self, scorer: PlanScorer, agent: int, pair: PairReplan | None = None,
                 regroup: bool = True) -> None:
        self.s = scorer
        self.p = scorer.p
        self.i = agent
        self.pair = pair
        self.regroup = regroup
        # agent-alone path scores bound joint ones only without prerequisites (a path
        # whose prerequisites another agent does is not feasible alone)
        self.bounds = not any(scorer.p.prereqs)

    def _best_insert(self, plan: Plan, changes: dict[int, tuple[int, ...]], k: int, j: int
                     ) -> tuple[float, dict[int, tuple[int, ...]]]:
        """Best position of task j in agent k's path (after `changes`): (score, changes)."""
        base = changes.get(k, plan[k])
        if len(base) >= self.p.max_depth or not self.p.eligible[k, j]:
            return -math.inf, changes
        best, best_changes = -math.inf, changes
        for q in insertions(base, j):
            c = {**changes, k: q}
            v = self._value(plan, c)
            if v > best:
                best, best_changes = v, c
        return best, best_changes

    def _value(self, plan: Plan, changes: dict[int, tuple[int, ...]]) -> float:
        if not self.s.groups:
            # paths are independent: the changed ones decide
            total = 0.0
            for k, q in changes.items():
                total += self.s.path_value(k, q) - self.s.path_value(k, plan[k])
            return self.base + total
        return self.s.score(with_changes(plan, changes))

    def best(self, plan: Plan) -> Proposal | None:
        p, i = self.p, self.i
        self.base = base = self.s.score(plan)
        holders: list[list[int]] = [[] for _ in range(p.n_tasks)]
        for k, q in enumerate(plan):
            for j in q:
                holders[j].append(k)
        mine = plan[i]
        best_v, best_c = base + _GAIN_TOL * max(1.0, abs(base)), None
        self.best_v = best_v
        self.alone = [self.s.path_value(k, q) for k, q in enumerate(plan)]

        def consider(v: float, c: dict[int, tuple[int, ...]]) -> None:
            nonlocal best_v, best_c
            if v > best_v:
                best_v, best_c = v, c
                self.best_v = v

        for j in range(p.n_tasks):
            if j in mine or not p.eligible[i, j]:
                continue
            need = int(p.required[j])
            owners = holders[j]
            # take j: from its holder, replacing a member, joining a short group
            sources: list[int | None] = list(owners) if len(owners) >= need else [None]
            for src in sources:
                c = {} if src is None else {src: without(plan[src], j)}
                v, c1 = self._best_insert(plan, c, i, j)
                consider(v, c1)
                if src is not None and need == 1 and v > -math.inf:
                    self._chain(plan, holders, c1, src, {i, src}, consider)
                # swap: give one of my tasks to src (or drop it) and take j
                for l in mine:
                    c2 = {**c, i: without(mine, l)}
                    if src is not None and l not in plan[src]:
                        v2, c3 = self._best_insert(plan, c2, src, l)
                        if v2 > -math.inf:
                            consider(*self._best_insert(plan, c3, i, j))
                    consider(*self._best_insert(plan, c2, i, j))
            if need > 1 and not owners:
                self._fill(plan, j, consider)
            elif need > 1 and self.regroup and len(owners) >= need:
                # move the whole group task: its members drop it, a new group takes it
                freed = {k: without(plan[k], j) for k in owners}
                if self._regroup_bound(plan, freed, j) > self.best_v:
                    self._fill(with_changes(plan, freed), j, consider, freed)
        # move one of my own tasks elsewhere in my path
        for l in mine:
            consider(*self._best_insert(plan, {i: without(mine, l)}, i, l))
        if self.pair is not None:
            self.pair.prepare(plan, base)
            for k in range(p.n_agents):
                if k != i:
                    self.pair.moves(plan, holders, k, consider)
        if best_c is None:
            return None
        changed = tuple(sorted((k, q) for k, q in best_c.items() if q != plan[k]))
        if not changed:
            return None
        return Proposal(i, best_v - base, changed)

    def _chain(self, plan: Plan, holders: list[list[int]], changes: dict[int, tuple[int, ...]],
               k: int, touched: set[int], consider) -> None:
        """Agent k, which has just lost a task, takes another single-agent task: an
        unassigned one, or one of an agent not yet changed, which in turn takes the best
        unassigned task it can (an ejection chain of up to three agents)."""
        p = self.p
        if not p.eligible[k].any():
            return
        for l in range(p.n_tasks):
            if p.required[l] != 1 or not p.eligible[k, l] or l in changes.get(k, plan[k]):
                continue
            owners = holders[l]
            m = owners[0] if owners else None
            if m is not None and m in touched:
                continue
            c = dict(changes) if m is None else {**changes, m: without(plan[m], l)}
            v, c1 = self._best_insert(plan, c, k, l)
            if v == -math.inf:
                continue
            consider(v, c1)
            if m is None:
                continue
            best_v, best_c = v, None
            for u in range(p.n_tasks):
                if holders[u] or u == l or p.required[u] != 1 or not p.eligible[m, u]:
                    continue
                if any(u in q for q in c1.values()):
                    continue
                v2, c2 = self._best_insert(plan, c1, m, u)
                if v2 > best_v:
                    best_v, best_c = v2, c2
            if best_c is not None:
                consider(best_v, best_c)

    def _fill(self, plan: Plan, j: int, consider,
              base: dict[int, tuple[int, ...]] | None = None) -> None:
        """Join group task j (no members yet) and complete its group with the partners
        that give the best plan, one at a time (`base`: changes already made to `plan`,
        kept in what is offered)."""
        p, i = self.p, self.i
        base_i = plan[i]
        if len(base_i) >= p.max_depth:
            return
        path_value = self.s.path_value
        alone = sum(path_value(k, q) for k, q in enumerate(plan))
        bounded = self.bounds and math.isfinite(alone)
        # my position is chosen with the full group in place: try each of my insertions
        for mine_q in insertions(base_i, j):
            c: dict[int, tuple[int, ...]] = {**(base or {}), i: mine_q}
            members = [i]
            ok = True
            while len(members) < p.required[j]:
                best_v, best_c, best_k = -math.inf, None, -1
                for k in range(p.n_agents):
                    if k in members or not p.eligible[k, j] or len(plan[k]) >= p.max_depth:
                        continue
                    for q in insertions(plan[k], j):
                        trial = {**c, k: q}
                        if len(members) + 1 == p.required[j]:
                            # no joint execution beats the agent-alone sum of the paths
                            bound = alone + sum(path_value(a, qa) - path_value(a, plan[a])
                                                for a, qa in trial.items())
                            if bounded and bound <= max(best_v, self.best_v):
                                continue
                            v = self._value(plan, trial)
                        else:
                            v = self._partial_value(plan, trial, j)
                        if v > best_v:
                            best_v, best_c, best_k = v, trial, k
                if best_c is None:
                    ok = False
                    break
                c = best_c
                members.append(best_k)
            if ok:
                consider(self._value(plan, c), c)

    def _regroup_bound(self, plan: Plan, freed: dict[int, tuple[int, ...]], j: int) -> float:
        """No regroup of j scores more: the agent-alone sum of all paths (which no joint
        execution exceeds) after the members drop j, plus the best agent-alone insertion
        gains of j for this agent and the best partners it needs."""
        p, i = self.p, self.i
        path_value = self.s.path_value
        if not self.bounds or not all(math.isfinite(v) for v in self.alone):
            return math.inf
        total = sum(self.alone) + sum(path_value(k, q) - self.alone[k]
                                      for k, q in freed.items())

        def gain(k: int) -> float:
            q0 = freed.get(k, plan[k])
            if not p.eligible[k, j] or len(q0) >= p.max_depth:
                return -math.inf
            return max(path_value(k, q) for q in insertions(q0, j)) - path_value(k, q0)

        partners = sorted((gain(k) for k in range(p.n_agents) if k != i), reverse=True)
        return total + gain(i) + sum(partners[: int(p.required[j]) - 1])

    def _partial_value(self, plan: Plan, changes: dict[int, tuple[int, ...]], j: int) -> float:
        """A group not yet full: the members' paths scored alone (j at each one's own
        arrival), which ranks the partners before the last one joins."""
        total = 0.0
        for k, q in changes.items():
            total += self.s.path_value(k, q) - self.s.path_value(k, plan[k])
        return total


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
