"""The plans of the `--refine` phase: proposals, scoring, and the opening guess.

A plan is every agent's path (task indices in execution order). `PlanScorer` scores plans
the way `evaluate_plan` does (a path sum when every task needs one agent); `canonical_plan`
drops the tasks that do not complete. `guess_plan` is the plan every agent can derive from
the agreed winners alone (see `refine.py`'s opening step).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import permutations

from murdoch.consensus.joint_score import joint_score
from murdoch.consensus.scoring import Problem, evaluate_plan, path_starts, task_value

Plan = tuple[tuple[int, ...], ...]
GAIN_TOL = 1e-7
_GUESS_PERMUTE = 6  # sets up to this size are ordered by trying every order


@dataclass(frozen=True)
class Proposal:
    agent: int
    gain: float
    paths: tuple[tuple[int, tuple[int, ...]], ...]  # (agent, its new path)

    def size(self) -> int:
        return 12 + sum(4 + 2 * len(q) for _, q in self.paths)


class PlanScorer:
    """Scores plans: a path sum when every task needs one agent (paths are then
    independent), the joint execution of `evaluate_plan` otherwise. A plan is valid when
    no task has more agents than it needs and every task on a path completes."""

    def __init__(self, p: Problem) -> None:
        self.p = p
        self.groups = bool((p.required > 1).any())
        self._paths: dict[tuple[int, tuple[int, ...]], float] = {}
        self._plans: dict[Plan, float] = {}  # joint scores of plans with group tasks

    def path_value(self, i: int, path: tuple[int, ...]) -> float:
        key = (i, path)
        v = self._paths.get(key)
        if v is None:
            p = self.p
            if len(path) > p.max_depth or not all(p.eligible[i, j] for j in path):
                v = -math.inf
            else:
                starts, ok = path_starts(p, i, list(path))
                if not ok:
                    v = -math.inf
                else:
                    lst = p.lists
                    v = 0.0
                    for j, t in zip(path, starts, strict=True):
                        v += task_value(lst, j, t)
            self._paths[key] = v
        return v

    def score(self, plan: Plan) -> float:
        """Total score of a valid plan; -inf for an invalid one."""
        p = self.p
        if not self.groups:
            held = [j for q in plan for j in q]
            if len(held) != len(set(held)):
                return -math.inf
            return sum(self.path_value(i, q) for i, q in enumerate(plan))
        count = [0] * p.n_tasks
        for i, q in enumerate(plan):
            if len(q) > p.max_depth:
                return -math.inf
            for j in q:
                if not p.eligible[i, j]:
                    return -math.inf
                count[j] += 1
        if any(c and c != p.required[j] for j, c in enumerate(count)):
            return -math.inf
        v = self._plans.get(plan)
        if v is None:
            v, completed = joint_score(p, plan)
            if not all(completed[j] for j, c in enumerate(count) if c):
                v = -math.inf
            self._plans[plan] = v
        return v


def canonical_plan(p: Problem, paths: Sequence[Sequence[int]]) -> Plan:
    """The plan without the tasks that do not complete (same score, every task done)."""
    ev = evaluate_plan(p, [list(q) for q in paths])
    return tuple(tuple(j for j in q if ev.completed[j]) for q in paths)


def with_changes(plan: Plan, changes: dict[int, tuple[int, ...]]) -> Plan:
    return tuple(changes.get(i, q) for i, q in enumerate(plan))


def insertions(path: tuple[int, ...], j: int) -> list[tuple[int, ...]]:
    return [(*path[:k], j, *path[k:]) for k in range(len(path) + 1)]


def without(path: tuple[int, ...], j: int) -> tuple[int, ...]:
    return tuple(x for x in path if x != j)




def guess_path(scorer: PlanScorer, agent: int, tasks: Sequence[int]) -> tuple[int, ...]:
    """An order of `agent`'s agreed tasks that every agent derives alike: the best
    agent-alone order (first in sorted order among equals) when there are at most
    `_GUESS_PERMUTE` tasks, otherwise by window opening (then index)."""
    p = scorer.p
    ts = sorted(tasks)
    if len(ts) <= _GUESS_PERMUTE:
        best, best_q = -math.inf, None
        for q in permutations(ts):
            v = scorer.path_value(agent, q)
            if v > best:
                best, best_q = v, q
        if best_q is not None:
            return best_q
    return tuple(sorted(ts, key=lambda j: (p.lists.window_start[j], j)))


def guess_plan(scorer: PlanScorer, sets: Sequence[Sequence[int]]) -> Plan:
    """`guess_path` for every agent (from the agreed winners: which tasks each holds)."""
    return tuple(guess_path(scorer, i, ts) for i, ts in enumerate(sets))
