"""One agent's search for its best proposal in the `--refine` phase (`refine.py`).

On its copy of the agreed plan an agent tries one-task moves (take, swap, move within its
path, short ejection chains), fills a group task nobody holds, moves a whole group task to
a new group (regroup), and re-plans itself with each other agent (`pair_replan.py`); the
best change that raises the total score is its proposal. Regroup and filling skip
candidates whose agent-alone bound cannot beat the best change found (without
prerequisites, where agent-alone scores bound joint ones).
"""

from __future__ import annotations

import math

from murdoch.consensus.pair_replan import PairReplan
from murdoch.consensus.refine_plan import (
    GAIN_TOL,
    Plan,
    PlanScorer,
    Proposal,
    insertions,
    with_changes,
    without,
)


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
        best_v, best_c = base + GAIN_TOL * max(1.0, abs(base)), None
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
