"""What an allocation run yields (`AllocationResult`) and the graph measures it is built from.

Shared by every way of running CBBA or CBGA: the synchronous rounds (`sync_runner`), the
asynchronous runner, the compiled kernels (`cbba_fast`, `cbga_fast`), SGA and refinement.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from murdoch.consensus.messages import dense_encoded_size
from murdoch.consensus.scoring import Problem, evaluate_plan


@dataclass(frozen=True)
class AllocationResult:
    algorithm: str
    assignment: dict[str, list[str]]
    start_times: dict[str, list[float | None]]
    total_score: float
    unassigned: list[str]
    incomplete: list[str]
    conflict_free: bool
    agreed: bool
    converged: bool
    comm_steps: int
    messages: int
    bytes: int
    rounds: int
    # sends in rounds 1..comm_steps whose allocation data differ from the sender's previous
    # round's (the CBGA paper's steps), and the bytes of those rounds' messages in the dense
    # form (`messages.dense_encoded_size`)
    pairwise_steps: int = 0
    bytes_dense: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "algorithm": self.algorithm,
            "assignment": self.assignment,
            "start_times": self.start_times,
            "total_score": round(self.total_score, 6),
            "unassigned": self.unassigned,
            "incomplete": self.incomplete,
            "conflict_free": self.conflict_free,
            "agreed": self.agreed,
            "converged": self.converged,
            "comm_steps": self.comm_steps,
            "messages": self.messages,
            "bytes": self.bytes,
            "rounds": self.rounds,
            "pairwise_steps": self.pairwise_steps,
            "bytes_dense": self.bytes_dense,
        }


def graph_diameter(neighbours: Sequence[Sequence[int]], active: Sequence[bool]) -> int:
    """Longest finite shortest path (in hops) among active agents; at least 1."""
    n = len(neighbours)
    out: list[list[int]] = [[] for _ in range(n)]
    for i, nbrs in enumerate(neighbours):
        for k in nbrs:
            out[k].append(i)  # information flows k -> i
    best = 1
    for src in range(n):
        if not active[src]:
            continue
        dist = {src: 0}
        queue = deque([src])
        while queue:
            a = queue.popleft()
            for b in out[a]:
                if b not in dist and active[b]:
                    dist[b] = dist[a] + 1
                    queue.append(b)
        best = max(best, max(dist.values()))
    return best


def build_result(algorithm: str, problem: Problem, paths: list[list[int]],
                 views: list[list[frozenset[int]]] | None, active: list[bool],
                 neighbours: Sequence[Sequence[int]], converged: bool, comm_steps: int,
                 messages: int, nbytes: int, rounds: int, pairwise_steps: int = 0,
                 bytes_dense: int | None = None) -> AllocationResult:
    """The result of a run (`bytes_dense` None: `messages` consensus messages of the
    algorithm, at `dense_message_size` each)."""
    s = problem.scenario
    if bytes_dense is None:
        bytes_dense = messages * dense_message_size(algorithm, problem)
    ev = evaluate_plan(problem, paths)
    groups = ev.group
    conflict_free = all(len(g) <= int(problem.required[j]) for j, g in enumerate(groups))
    conflict_free &= all(len(set(p)) == len(p) for p in paths)
    agreed = True
    if views is not None:
        truth = [frozenset(g) for g in groups]
        for comp in components(neighbours, active):
            ref = [frozenset(m for m in w if m in comp) for w in truth]
            for i in comp:
                if [frozenset(m for m in w if m in comp) for w in views[i]] != ref:
                    agreed = False
    assignment = {s.agents[i].id: [s.tasks[j].id for j in paths[i]]
                  for i in range(problem.n_agents) if active[i]}
    start_times = {
        s.agents[i].id: [None if math.isnan(t) else round(t, 6) for t in ev.start_times[i]]
        for i in range(problem.n_agents) if active[i]
    }
    unassigned = [s.tasks[j].id for j in range(problem.n_tasks) if not ev.completed[j]]
    incomplete = [s.tasks[j].id for j in range(problem.n_tasks)
                  if not ev.completed[j] and groups[j]]
    return AllocationResult(
        algorithm=algorithm, assignment=assignment, start_times=start_times,
        total_score=ev.total_score, unassigned=unassigned, incomplete=incomplete,
        conflict_free=bool(conflict_free), agreed=agreed, converged=converged,
        comm_steps=comm_steps, messages=messages, bytes=nbytes, rounds=rounds,
        pairwise_steps=pairwise_steps, bytes_dense=bytes_dense)


def dense_message_size(algorithm: str, problem: Problem) -> int:
    """One consensus message of this run in the dense form: CBBA's (y, z) vectors; CBGA's
    (tasks x max L_j) winners and bids, with start times when there are group tasks."""
    width = int(problem.required.max()) if problem.n_tasks else 1
    starts = algorithm == "cbga" and width > 1
    return dense_encoded_size(problem.n_tasks, width, problem.n_agents, starts)


def components(neighbours: Sequence[Sequence[int]], active: Sequence[bool]) -> list[set[int]]:
    """Weakly connected components of the active agents."""
    n = len(neighbours)
    adj: list[set[int]] = [set() for _ in range(n)]
    for i, nbrs in enumerate(neighbours):
        for k in nbrs:
            adj[i].add(k)
            adj[k].add(i)
    seen: set[int] = set()
    out: list[set[int]] = []
    for i in range(n):
        if i in seen or not active[i]:
            continue
        comp = {i}
        stack = [i]
        while stack:
            a = stack.pop()
            for b in adj[a]:
                if b not in comp and active[b]:
                    comp.add(b)
                    stack.append(b)
        seen |= comp
        out.append(comp)
    return out
