"""Exact optimum of small allocation problems, by enumeration with branch and bound.

The objective is the one `murdoch allocate` reports: `scoring.evaluate_plan` executes every
agent's path jointly and sums, per completed task, its score at the joint start once per
member. The optimum is taken over the plans the allocators can produce: each task done by
exactly `agents_required` agents that may do its type (capabilities), a group covering the
task's equipment, a single-agent task by an agent carrying all of it, at most `max_depth`
tasks per agent. A plan holding a task that cannot complete scores the same as the plan
without it, so only plans whose every task completes are searched.

How:

1. **Sequences per agent.** Every feasible path of each agent is enumerated, each task
   timed as the agent alone would start it (arrival at its speed, not before the window
   opens, at most the latest start). For single-agent tasks that is the real timing; for a
   group task the joint start is the latest of the members' arrivals, which is never
   earlier, so with non-negative discounts the agent-alone score of a path is an upper
   bound of what the path earns in any joint plan.
2. **Single-agent tasks only**: keep the best path per task set and combine the agents by
   dynamic programming over disjoint task sets (exact: the scores are additive).
3. **Group tasks**: enumerate who does each group task (none, or a group of the right size
   that covers its equipment), order these choices by the relaxed optimum of step 2 (with
   each agent's group tasks fixed) and, while a choice's bound beats the best plan found,
   search the agents' paths depth first with the relaxed bound, evaluating complete plans
   with `evaluate_plan`.

Prerequisites and negative discounts are not handled (a `ValueError` says so); both are
outside the small benchmark problems this is for. `node_limit` bounds the work and raises
`ExactTooLarge` instead of running for hours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations, product

from murdoch.consensus.scenario import Scenario
from murdoch.consensus.scoring import (
    _EPS,
    Problem,
    build_problem,
    evaluate_plan,
    task_value,
)

_TOL = 1e-9


class ExactTooLarge(ValueError):
    """The instance needs more search than the node limit allows."""


@dataclass(frozen=True)
class ExactSolution:
    paths: tuple[tuple[int, ...], ...]  # per agent, task indices in execution order
    total_score: float
    nodes: int  # sequences enumerated plus search nodes visited


@dataclass(frozen=True)
class _Seq:
    mask: int  # tasks on the path (bit j)
    path: tuple[int, ...]
    score: float  # agent-alone score (exact for single-agent tasks, a bound for groups)


def agent_sequences(p: Problem, agent: int, tasks: list[int], limit: int
                    ) -> list[_Seq]:
    """Every feasible path of `agent` over `tasks` (the empty path included), timed as the
    agent alone would start each task."""
    lst = p.lists
    speed = lst.speed[agent]
    out: list[_Seq] = [_Seq(0, (), 0.0)]
    budget = [limit]

    def extend(path: tuple[int, ...], mask: int, ready: float, row: list[float],
               score: float) -> None:
        if len(path) >= p.max_depth:
            return
        for j in tasks:
            if mask >> j & 1:
                continue
            start = ready + row[j] / speed
            ws = lst.window_start[j]
            if start < ws:
                start = ws
            if start > lst.window_end[j] + _EPS:
                continue
            gain = task_value(lst, j, start)
            new_path = (*path, j)
            new_mask = mask | (1 << j)
            out.append(_Seq(new_mask, new_path, score + gain))
            budget[0] -= 1
            if budget[0] < 0:
                raise ExactTooLarge(f"agent {agent}: more than {limit} feasible paths")
            extend(new_path, new_mask, start + lst.duration[j], lst.task_task_dist[j],
                   score + gain)

    extend((), 0, lst.availability[agent], lst.agent_task_dist[agent], 0.0)
    return out


def _best_per_mask(seqs: list[_Seq]) -> dict[int, _Seq]:
    best: dict[int, _Seq] = {}
    for s in seqs:
        b = best.get(s.mask)
        if b is None or s.score > b.score:
            best[s.mask] = s
    return best


def _combine(per_agent: list[dict[int, _Seq]], shared: int = 0
             ) -> tuple[float, list[tuple[int, ...]]]:
    """Best sum over agents of task sets disjoint outside `shared` (the group tasks, fixed
    beforehand): dynamic programming over the union of the sets used."""
    table: dict[int, tuple[float, tuple[tuple[int, ...], ...]]] = {0: (0.0, ())}
    for best in per_agent:
        items = sorted(best.items())
        nxt: dict[int, tuple[float, tuple[tuple[int, ...], ...]]] = {}
        for used, (score, paths) in table.items():
            for mask, seq in items:
                own = mask & ~shared
                if used & own:
                    continue
                key = used | own
                total = score + seq.score
                old = nxt.get(key)
                if old is None or total > old[0]:
                    nxt[key] = (total, (*paths, seq.path))
        table = nxt
    score, paths = max(table.values(), key=lambda v: v[0])
    return score, list(paths)


def _groups_for(p: Problem, j: int) -> list[tuple[int, ...]]:
    """Every group of agents that may do group task j (size, capabilities, equipment)."""
    need = p.task_equipment[j]
    members = [i for i in range(p.n_agents) if p.eligible[i, j]]
    out = []
    for combo in combinations(members, int(p.required[j])):
        covered: set[str] = set()
        for i in combo:
            covered |= p.agent_equipment[i]
        if need <= covered:
            out.append(combo)
    return out


def _group_choices(p: Problem, seqs: list[list[_Seq]], group_tasks: list[int],
                   group_mask: int) -> list[tuple[float, list[list[_Seq]]]]:
    """Every choice of groups for the group tasks that each agent's paths can serve: the
    agents' candidate paths under it and the bound on its score, best bound first."""
    n = p.n_agents
    options = [[(), *_groups_for(p, j)] for j in group_tasks]
    by_group_part: list[dict[int, list[_Seq]]] = []
    for i in range(n):
        parts: dict[int, list[_Seq]] = {}
        for s in seqs[i]:
            parts.setdefault(s.mask & group_mask, []).append(s)
        for lst in parts.values():
            lst.sort(key=lambda s: -s.score)
        by_group_part.append(parts)

    choices: list[tuple[float, list[list[_Seq]]]] = []
    for pick in product(*options):
        fixed = [0] * n
        for j, grp in zip(group_tasks, pick, strict=True):
            for i in grp:
                fixed[i] |= 1 << j
        cands = [by_group_part[i].get(fixed[i], []) for i in range(n)]
        if any(not c for c in cands):
            continue
        bound, _ = _combine([_best_per_mask(c) for c in cands], group_mask)
        choices.append((bound, cands))
    choices.sort(key=lambda c: -c[0])
    return choices


def solve_exact(scenario: Scenario | Problem, node_limit: int = 2_000_000) -> ExactSolution:
    """The best plan of a small scenario and its score (see the module text)."""
    p = scenario if isinstance(scenario, Problem) else build_problem(scenario)
    if any(p.prereqs):
        raise ValueError("the exact solver does not handle prerequisites")
    if p.cost == "discount" and (p.discount < 0).any():
        raise ValueError("the exact solver needs non-negative discounts")
    n, m = p.n_agents, p.n_tasks
    if m > 60:
        raise ExactTooLarge(f"{m} tasks is far beyond an exact search")
    group_tasks = [j for j in range(m) if p.required[j] > 1]
    group_mask = sum(1 << j for j in group_tasks)
    seqs = []
    for i in range(n):
        allowed = [j for j in range(m) if p.eligible[i, j]]
        seqs.append(agent_sequences(p, i, allowed, node_limit))
    nodes = sum(len(s) for s in seqs)
    if not group_tasks:
        _score, paths = _combine([_best_per_mask(s) for s in seqs])
        ev = evaluate_plan(p, [list(q) for q in paths])
        return ExactSolution(tuple(paths), ev.total_score, nodes)

    choices = _group_choices(p, seqs, group_tasks, group_mask)

    best_score = -1.0
    best_paths: list[tuple[int, ...]] = [() for _ in range(n)]
    for bound, cands in choices:
        if bound <= best_score + _TOL:
            break
        best_sets = [sorted(_best_per_mask(c).values(), key=lambda s: -s.score)
                     for c in cands]
        memo: dict[tuple[int, int], float] = {}

        def rest(i: int, used: int, best_sets: list[list[_Seq]] = best_sets,
                 memo: dict[tuple[int, int], float] = memo) -> float:
            """Best agent-alone sum of agents i.. whose single-agent tasks avoid `used`
            (a bound of what they add to any plan)."""
            if i == n:
                return 0.0
            key = (i, used)
            v = memo.get(key)
            if v is None:
                v = -math.inf
                for s in best_sets[i]:
                    if s.score + rest(i + 1, 0) <= v:
                        break
                    single = s.mask & ~group_mask
                    if used & single:
                        continue
                    v = max(v, s.score + rest(i + 1, used | single))
                memo[key] = v
            return v

        chosen: list[tuple[int, ...]] = []

        def search(i: int, used: int, partial: float, cands: list[list[_Seq]] = cands,
                   rest=rest, chosen: list[tuple[int, ...]] = chosen) -> None:
            nonlocal best_score, best_paths, nodes
            if i == n:
                total = evaluate_plan(p, [list(q) for q in chosen]).total_score
                if total > best_score + _TOL:
                    best_score, best_paths = total, list(chosen)
                return
            loose = rest(i + 1, used)
            for s in cands[i]:
                if partial + s.score + loose <= best_score + _TOL:
                    break  # sorted by score: no later path does better
                single = s.mask & ~group_mask
                if used & single:
                    continue
                if partial + s.score + rest(i + 1, used | single) <= best_score + _TOL:
                    continue
                nodes += 1
                if nodes > node_limit:
                    raise ExactTooLarge(f"more than {node_limit} search nodes")
                chosen.append(s.path)
                search(i + 1, used | single, partial + s.score)
                chosen.pop()

        search(0, 0, 0.0)
    return ExactSolution(tuple(best_paths), max(best_score, 0.0), nodes)
