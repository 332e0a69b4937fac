"""The total score of a joint plan, as `scoring.evaluate_plan` computes it, in plain Python.

`evaluate_plan` is the reference (start times per agent, groups, numpy arrays); the
improvement phase of `--refine` scores thousands of candidate plans with group tasks and
needs only the total and which tasks complete. This restates the same execution with the
problem's lists: a task is usable when its whole group (`agents_required` agents covering
its equipment) holds it; members start it together when all have arrived, not before the
window opens and after its prerequisites; a task that cannot start in its window is
skipped by its members; agents waiting on each other in a cycle drop the lowest-index
blocked task. Scores use `math.exp` where `evaluate_plan` uses numpy's, so totals agree to
rounding (`test_consensus_refine_pairs.py` compares both on random plans).
"""

from __future__ import annotations

from collections.abc import Sequence

from murdoch.consensus.scoring import _EPS, Problem, task_value


def joint_score(p: Problem, paths: Sequence[Sequence[int]]) -> tuple[float, list[bool]]:
    """(total score, completed per task) of executing `paths` jointly."""
    lst = p.lists
    m = p.n_tasks
    n = len(paths)
    group: list[list[int]] = [[] for _ in range(m)]
    for i, path in enumerate(paths):
        for j in path:
            group[j].append(i)
    usable = [False] * m
    for j in range(m):
        members = group[j]
        if len(members) != lst.required[j]:
            continue
        need = p.task_equipment[j]
        if need:
            covered: set[str] = set()
            for i in members:
                covered |= p.agent_equipment[i]
            if not need <= covered:
                continue
        if lst.required[j] == 1 and not lst.eligible[members[0]][j]:
            continue
        usable[j] = True
    queues = [[j for j in path if usable[j]] for path in paths]
    ptr = [0] * n
    ready = [lst.availability[i] for i in range(n)]
    pos = [-1] * n
    completed = [False] * m
    start_of = [0.0] * m
    finish: dict[int, float] = {}
    remaining = sum(len(q) for q in queues)
    while remaining:
        progressed = False
        for i in range(n):
            qi = queues[i]
            while ptr[i] < len(qi):
                j = qi[ptr[i]]
                members = group[j]
                if not all(ptr[k] < len(queues[k]) and queues[k][ptr[k]] == j
                           for k in members):
                    break
                arrive = 0.0
                for k in members:
                    d = (lst.agent_task_dist[k][j] if pos[k] < 0
                         else lst.task_task_dist[pos[k]][j])
                    arrive = max(arrive, ready[k] + d / lst.speed[k])
                start = max(lst.window_start[j], arrive)
                ok = True
                for q in p.prereqs[j]:
                    if q in finish:
                        start = max(start, finish[q])
                    else:
                        ok = False
                ok = ok and start <= lst.window_end[j] + _EPS
                for k in members:
                    ptr[k] += 1
                    remaining -= 1
                    if ok:
                        ready[k] = start + lst.duration[j]
                        pos[k] = j
                if ok:
                    completed[j] = True
                    start_of[j] = start
                    finish[j] = start + lst.duration[j]
                progressed = True
        if not progressed:
            blocked = min(queues[i][ptr[i]] for i in range(n) if ptr[i] < len(queues[i]))
            for k in group[blocked]:
                if ptr[k] < len(queues[k]) and queues[k][ptr[k]] == blocked:
                    ptr[k] += 1
                else:
                    queues[k].remove(blocked)
                remaining -= 1
    total = 0.0
    for j in range(m):
        if completed[j]:
            total += len(group[j]) * task_value(lst, j, start_of[j])
    return total, completed
