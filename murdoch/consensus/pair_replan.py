"""A bounded re-plan of two agents' combined tasks: the pair move of `--refine`.

One agent (the proposer) takes another agent and re-plans the two of them on its copy of
the agreed plan, leaving everyone else's path as it is. The tasks considered are the
single-agent tasks either of the two holds, plus the unassigned single-agent tasks one of
them may do (the most valuable first, up to `max_tasks` in all); group tasks the pair is in
may change hands inside the pair (the partner outside the pair stays), and a two-agent task
nobody holds may be taken by both.

For each choice of group tasks, every feasible path of each agent over those tasks is
enumerated (`exact.agent_sequences`, timed as the agent alone would start each task), the
best path per task set is kept, and the two agents are combined over disjoint task sets by
a best-subset table of the second agent (a sum over subsets, 2^k entries for k tasks). With
single-agent tasks only, the agent-alone score is the real one and the pair's re-plan is
optimal for the tasks considered. With group tasks it is an upper bound: candidate pairs of
paths are evaluated jointly (`PlanScorer.score`), best bound first, until the bound cannot
beat the best one found or `max_joint` evaluations have been spent.

This moves several tasks between two agents at once (two-for-one and two-for-two
exchanges, re-ordered paths), which the one-task moves of `refine.MoveSearch` do not reach.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from itertools import product
from typing import TYPE_CHECKING

from murdoch.consensus.exact import ExactTooLarge, agent_sequences

if TYPE_CHECKING:
    from murdoch.consensus.refine_plan import Plan, PlanScorer

Changes = dict[int, tuple[int, ...]]
_SEQ_LIMIT = 20_000
_MAX_CHOICES = 16
_ORDERS = 4  # orders kept per task set
_TOP_SINGLE = 6  # best re-plans offered with single-agent tasks only


class PairReplan:
    """The pair move for one proposer; enumerations are cached across steps."""

    def __init__(self, scorer: PlanScorer, agent: int, max_tasks: int = 9,
                 max_joint: int = 24) -> None:
        self.s = scorer
        self.p = scorer.p
        self.i = agent
        self.max_tasks = max_tasks
        self.max_joint = max_joint
        self._seqs: dict[tuple[int, tuple[int, ...]],
                         dict[int, list[tuple[float, tuple[int, ...]]]] | None] = {}

    def _best_paths(self, agent: int, tasks: tuple[int, ...]
                    ) -> dict[int, list[tuple[float, tuple[int, ...]]]] | None:
        """Per task set (a bit mask of task indices), the agent-alone (score, path) of its
        best orders, best first (a few: with group tasks the best joint order may differ)."""
        key = (agent, tasks)
        if key not in self._seqs:
            allowed = [j for j in tasks if self.p.eligible[agent, j]]
            try:
                seqs = agent_sequences(self.p, agent, allowed, _SEQ_LIMIT)
            except ExactTooLarge:
                self._seqs[key] = None
                return None
            best: dict[int, list[tuple[float, tuple[int, ...]]]] = {}
            for sq in seqs:
                best.setdefault(sq.mask, []).append((sq.score, sq.path))
            for orders in best.values():
                orders.sort(key=lambda o: -o[0])
                del orders[_ORDERS:]
            self._seqs[key] = best
        return self._seqs[key]

    def moves(self, plan: Plan, holders: list[list[int]], k: int,
              consider: Callable[[float, Changes], None]) -> None:
        """Offer `consider` the best re-plans of agents i and k (see the module text)."""
        p, i = self.p, self.i
        req = p.required
        singles = sorted({j for j in (*plan[i], *plan[k]) if req[j] == 1})
        free = [j for j in range(p.n_tasks) if req[j] == 1 and not holders[j]
                and (p.eligible[i, j] or p.eligible[k, j])]
        lst = p.lists
        free.sort(key=lambda j: -max(lst.gain_bound[i][j], lst.gain_bound[k][j]))
        room = max(0, self.max_tasks - len(singles))
        singles = sorted(singles + free[:room])
        # group tasks: who of the pair is in each (the partners outside the pair stay)
        group_opts: list[tuple[int, list[tuple[bool, bool]]]] = []
        for j in sorted({j for j in (*plan[i], *plan[k]) if req[j] > 1}):
            others = [m for m in holders[j] if m != i and m != k]
            need = int(req[j]) - len(others)
            if need == 1:
                opts = [(True, False), (False, True)]
                opts = [o for o in opts if p.eligible[i if o[0] else k, j]]
            else:
                opts = [(j in plan[i], j in plan[k])]
            group_opts.append((j, opts))
        for j in range(p.n_tasks):
            if req[j] == 2 and not holders[j] and p.eligible[i, j] and p.eligible[k, j]:
                group_opts.append((j, [(False, False), (True, True)]))
        choices = 1
        kept: list[tuple[int, list[tuple[bool, bool]]]] = []
        for j, opts in group_opts:
            if choices * len(opts) > _MAX_CHOICES:
                kept.append((j, [(j in plan[i], j in plan[k])]))
                continue
            choices *= len(opts)
            kept.append((j, opts))
        group_tasks = tuple(j for j, _ in kept)
        cands: list[tuple[float, list[tuple[int, ...]], list[tuple[int, ...]]]] = []
        for pick in product(*(opts for _, opts in kept)):
            gi = tuple(j for j, o in zip(group_tasks, pick, strict=True) if o[0])
            gk = tuple(j for j, o in zip(group_tasks, pick, strict=True) if o[1])
            found = self._combine(singles, gi, gk, k)
            if found is not None:
                cands.extend(found)
        if not cands:
            return
        cands.sort(key=lambda c: -c[0])
        old = self.s.path_value(i, plan[i]) + self.s.path_value(k, plan[k])
        released = [j for j in (*plan[i], *plan[k]) if req[j] == 1]
        if not self.s.groups:
            for bound, qis, qks in cands[:_TOP_SINGLE]:
                c = {i: qis[0], k: qks[0]}
                if c[i] == plan[i] and c[k] == plan[k]:
                    continue
                extra, c = self._hand_on(plan, c, released)
                consider(self._base + bound - old + extra, c)
            return
        # the joint score is at most the agent-alone sum of all paths, and the tasks
        # handed on gain at most their own bound each
        hand = [max([0.0, *(lst.gain_bound[m][j] for m in range(p.n_agents)
                            if m != i and m != k and p.eligible[m, j])])
                for j in range(p.n_tasks)]
        ranked = sorted(((bound + self._alone_total - old
                          + sum(hand[j] for j in released
                                if j not in qis[0] and j not in qks[0]), qis, qks)
                         for bound, qis, qks in cands), key=lambda c: -c[0])
        best_v = -math.inf
        best_c: Changes | None = None
        spent = 0
        for ub, qis, qks in ranked:
            if spent >= self.max_joint or (best_c is not None and ub <= best_v):
                break
            for qi, qk in product(qis, qks):
                spent += 1
                c = {i: qi, k: qk}
                for trial in (c, self._hand_on(plan, c, released)[1]):
                    v = self.s.score(tuple(trial.get(a, q) for a, q in enumerate(plan)))
                    if v > best_v:
                        best_v, best_c = v, trial
        if best_c is not None:
            consider(best_v, best_c)

    def _hand_on(self, plan: Plan, changes: Changes, released: list[int]
                 ) -> tuple[float, Changes]:
        """The single-agent tasks the pair gave up, handed one at a time (largest gain
        first) to the third agents, each inserted where it gains most (agent-alone):
        (gain, changes)."""
        p = self.p
        kept = {j for q in changes.values() for j in q}
        left = [j for j in released if j not in kept]
        gain = 0.0
        out = dict(changes)
        third = [m for m in range(p.n_agents) if m not in changes]
        while left:
            best_g, best_m, best_j = 0.0, -1, -1
            best_q: tuple[int, ...] = ()
            for m in third:
                path = out.get(m, plan[m])
                if len(path) >= p.max_depth:
                    continue
                now = self.s.path_value(m, path)
                for j in left:
                    if not p.eligible[m, j]:
                        continue
                    for pos in range(len(path) + 1):
                        q = (*path[:pos], j, *path[pos:])
                        g = self.s.path_value(m, q) - now
                        if g > best_g:
                            best_g, best_m, best_j, best_q = g, m, j, q
            if best_m < 0:
                break
            out[best_m] = best_q
            gain += best_g
            left.remove(best_j)
        return gain, out

    def prepare(self, plan: Plan, base: float) -> None:
        """Set the plan's score and the agent-alone sum of all its paths (with the pair's
        bound in place of the pair's share, a bound of the whole plan's joint score)."""
        self._base = base
        self._alone_total = sum(self.s.path_value(a, q) for a, q in enumerate(plan))

    def _combine(self, singles: list[int], gi: tuple[int, ...], gk: tuple[int, ...], k: int
                 ) -> list[tuple[float, list[tuple[int, ...]], list[tuple[int, ...]]]] | None:
        """Per task set of agent i, its best orders with the best orders of the best
        disjoint task set of k: (agent-alone score of both best, orders of i, of k)."""
        i = self.i
        bi = self._best_paths(i, tuple(sorted((*singles, *gi))))
        bk = self._best_paths(k, tuple(sorted((*singles, *gk))))
        if bi is None or bk is None:
            return None
        gmask_i = sum(1 << j for j in gi)
        gmask_k = sum(1 << j for j in gk)
        local = {j: b for b, j in enumerate(singles)}
        full = (1 << len(singles)) - 1

        def to_local(mask: int) -> int:
            out = 0
            m = mask
            while m:
                low = m & -m
                out |= 1 << local[low.bit_length() - 1]
                m ^= low
            return out

        gmask = sum(1 << j for j in range(self.p.n_tasks) if self.p.required[j] > 1)
        # best orders of k per local set of single tasks, then best over subsets
        table: list[tuple[float, list[tuple[int, ...]]] | None] = [None] * (full + 1)
        for mask, orders in bk.items():
            if mask & gmask != gmask_k:
                continue
            lm = to_local(mask & ~gmask)
            t = table[lm]
            if t is None or orders[0][0] > t[0]:
                table[lm] = (orders[0][0], [o[1] for o in orders])
        for b in range(len(singles)):
            bit = 1 << b
            for m in range(full + 1):
                if m & bit:
                    a, c = table[m ^ bit], table[m]
                    if a is not None and (c is None or a[0] > c[0]):
                        table[m] = a
        out = []
        for mask, orders in bi.items():
            if mask & gmask != gmask_i:
                continue
            rest = table[full & ~to_local(mask & ~gmask)]
            if rest is None:
                continue
            out.append((orders[0][0] + rest[0], [o[1] for o in orders], rest[1]))
        return out
