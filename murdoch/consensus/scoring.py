"""Problem data, path timing with time windows, and joint plan evaluation.

A path is an agent's list of task indices in execution order. Each task starts as early as
possible: when the agent has arrived (straight-line travel at its speed), not before its window
opens, and not before its prerequisites (which must be earlier on the same path) have finished.
With time windows a task scores ``reward * exp(-discount * (start - window_start))`` and the
path is feasible only if every start is at most the window's latest start; without time windows
the reference time is 0 and there is no latest start. With the scenario's ``cost: "paper"`` a
task scores ``reward - ((start - reference) + duration)`` instead (the CBGA paper's eq. 7/8:
the reward less the time until the group's latest arrival and the task's duration, in
seconds; `discount` is not used). Both fall with the start; the linear one can go negative.

Marginal gains of inserting a task into a path are in `gains.py`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from murdoch.consensus.scenario import Scenario

_EPS = 1e-9
# what a linear score's upper bound adds, relative to 1 + |bound|: the bound and the gain
# it bounds are computed along different paths and may differ in their last bits
LINEAR_MARGIN = 1e-9


@dataclass(frozen=True)
class _Lists:
    agent_task_dist: list[list[float]]
    task_task_dist: list[list[float]]
    window_start: list[float]
    window_end: list[float]
    duration: list[float]
    speed: list[float]
    availability: list[float]
    reward: list[float]
    discount: list[float]
    score_ref: list[float]
    gain_bound: list[list[float]]
    eligible: list[list[bool]]
    required: list[int]
    team_reward: list[float]
    linear: bool  # the paper's cost: reward - ((start - ref) + duration)
    # per task: window start, latest start + tolerance, duration, score reference time,
    # reward, discount (what an insertion evaluation reads)
    task_params: list[tuple[float, float, float, float, float, float]]


@dataclass(frozen=True)
class Problem:
    """Numeric arrays derived from a scenario (indices follow the scenario's list order)."""

    scenario: Scenario
    n_agents: int
    n_tasks: int
    agent_pos: np.ndarray  # (N, D)
    speed: np.ndarray  # (N,)
    availability: np.ndarray  # (N,)
    task_pos: np.ndarray  # (M, D)
    window_start: np.ndarray  # (M,)
    window_end: np.ndarray  # (M,) latest start, inf when open
    score_ref: np.ndarray  # (M,) time the discount counts from
    duration: np.ndarray  # (M,)
    reward: np.ndarray  # (M,)
    discount: np.ndarray  # (M,)
    required: np.ndarray  # (M,) agents needed
    eligible: np.ndarray  # (N, M) bool: capability (and full equipment for L_j = 1)
    agent_task_dist: np.ndarray  # (N, M)
    task_task_dist: np.ndarray  # (M, M)
    prereqs: tuple[tuple[int, ...], ...]  # per task, indices of its prerequisites
    has_prereqs: np.ndarray  # (M,) bool
    agent_equipment: tuple[frozenset[str], ...]
    task_equipment: tuple[frozenset[str], ...]
    quit_after: np.ndarray  # (M,) inf = never
    team_reward: np.ndarray  # (M,)
    max_depth: int
    cost: str  # `scenario.COSTS`; "paper" scores linearly (`linear` in `lists`)
    gain_bound: np.ndarray  # (N, M): no insertion can gain more (direct travel, no delays)
    lists: _Lists  # the same numbers as Python lists, for the scalar path walk


def build_problem(s: Scenario) -> Problem:
    n, m = len(s.agents), len(s.tasks)
    dim = len(s.agents[0].pos)
    agent_pos = np.array([a.pos for a in s.agents], dtype=float).reshape(n, dim)
    task_pos = np.array([t.pos for t in s.tasks], dtype=float).reshape(m, dim)
    if s.time_windows:
        ws = np.array([t.start_s for t in s.tasks], dtype=float)
        we = np.array([t.end_s for t in s.tasks], dtype=float)
        ref = ws.copy()
    else:
        ws = np.zeros(m)
        we = np.full(m, np.inf)
        ref = np.zeros(m)
    eligible = np.zeros((n, m), dtype=bool)
    for i, a in enumerate(s.agents):
        for j, t in enumerate(s.tasks):
            ok = a.capabilities is None or t.type in a.capabilities
            if t.agents_required == 1 and not t.equipment <= a.equipment:
                ok = False
            if t.agents_required > 1 and len(s.agents) < t.agents_required:
                ok = False
            eligible[i, j] = ok
    index = {t.id: j for j, t in enumerate(s.tasks)}
    prereqs = tuple(tuple(index[p] for p in t.prerequisites) for t in s.tasks)
    speed = np.array([a.speed_mps for a in s.agents], dtype=float)
    availability = np.array([a.availability_s for a in s.agents], dtype=float)
    reward = np.array([t.reward for t in s.tasks], dtype=float)
    discount = np.array([t.discount for t in s.tasks], dtype=float)
    duration = np.array([t.duration_s for t in s.tasks], dtype=float)
    at_dist = (np.linalg.norm(agent_pos[:, None, :] - task_pos[None, :, :], axis=2)
               if m else np.zeros((n, 0)))
    tt_dist = (np.linalg.norm(task_pos[:, None, :] - task_pos[None, :, :], axis=2)
               if m else np.zeros((0, 0)))
    earliest = np.maximum(ws[None, :], availability[:, None] + at_dist / speed[:, None])
    linear = s.cost == "paper"
    if linear:
        # a linear score: an additive margin (a relative one would lower a negative bound)
        own = reward[None, :] - duration[None, :] - (earliest - ref[None, :])
        own = own + LINEAR_MARGIN * (1.0 + np.abs(own))
    else:
        own = reward[None, :] * np.exp(-discount[None, :] * (earliest - ref[None, :]))
    bound = np.where(earliest <= we[None, :] + _EPS, own, -np.inf)
    required = np.array([t.agents_required for t in s.tasks], dtype=np.int64)
    lists = _Lists(at_dist.tolist(), tt_dist.tolist(), ws.tolist(), we.tolist(),
                   duration.tolist(), speed.tolist(), availability.tolist(), reward.tolist(),
                   discount.tolist(), ref.tolist(), bound.tolist(), eligible.tolist(),
                   required.tolist(), [t.team_reward for t in s.tasks], linear,
                   [(float(ws[j]), float(we[j]) + _EPS, float(duration[j]), float(ref[j]),
                     float(reward[j]), float(discount[j])) for j in range(m)])
    return Problem(
        scenario=s, n_agents=n, n_tasks=m, agent_pos=agent_pos,
        speed=speed, availability=availability,
        task_pos=task_pos, window_start=ws, window_end=we, score_ref=ref,
        duration=duration, reward=reward, discount=discount,
        required=required,
        eligible=eligible,
        agent_task_dist=at_dist, task_task_dist=tt_dist,
        prereqs=prereqs,
        has_prereqs=np.array([bool(p) for p in prereqs], dtype=bool),
        agent_equipment=tuple(a.equipment for a in s.agents),
        task_equipment=tuple(t.equipment for t in s.tasks),
        quit_after=np.array([np.inf if t.quit_after is None else t.quit_after
                             for t in s.tasks], dtype=float),
        team_reward=np.array([t.team_reward for t in s.tasks], dtype=float),
        max_depth=s.bundle_limit,
        cost=s.cost,
        gain_bound=bound,
        lists=lists,
    )


def task_scores(p: Problem, tasks: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Score of each task when started at the given time."""
    if p.lists.linear:
        return p.reward[tasks] - p.duration[tasks] - (starts - p.score_ref[tasks])
    return p.reward[tasks] * np.exp(-p.discount[tasks] * (starts - p.score_ref[tasks]))


def task_value(lst: _Lists, j: int, start: float) -> float:
    """`task_scores` of one task, in plain Python (the same operations as the insertion
    gains of `gains.py` and the compiled kernels)."""
    if lst.linear:
        return lst.reward[j] - lst.duration[j] - (start - lst.score_ref[j])
    return lst.reward[j] * math.exp(-lst.discount[j] * (start - lst.score_ref[j]))


def path_times(p: Problem, agent: int, path: list[int],
               lower_bounds: dict[int, float] | None = None,
               ready_out: list[float] | None = None) -> tuple[np.ndarray, bool]:
    """`path_starts` as an array."""
    starts, ok = path_starts(p, agent, path, lower_bounds, ready_out)
    return np.array(starts), ok


def path_starts(p: Problem, agent: int, path: list[int],
                lower_bounds: dict[int, float] | None = None,
                ready_out: list[float] | None = None,
                bad_out: list[int] | None = None) -> tuple[list[float], bool]:
    """Earliest start times along a path and whether every start fits its window.

    `lower_bounds` optionally adds a not-before time per task (used for group tasks whose
    start waits for the whole group). Prerequisites must appear earlier on the path.
    `ready_out`, when given, receives for each task the time this agent could start it on
    its own (the start before any group lower bound). `bad_out`, when given, receives the
    index of the first task that does not fit (nothing when all fit).
    """
    lst = p.lists
    out: list[float] = []
    ready = lst.availability[agent]
    speed = lst.speed[agent]
    dist_row = lst.agent_task_dist[agent]
    ok = True
    finish: dict[int, float] = {}
    for j in path:
        start = ready + dist_row[j] / speed
        ws = lst.window_start[j]
        if ws > start:
            start = ws
        for q in p.prereqs[j]:
            if q not in finish:
                ok = False
            elif finish[q] > start:
                start = finish[q]
        if ready_out is not None:
            ready_out.append(start)
        if lower_bounds is not None and j in lower_bounds:
            start = max(start, lower_bounds[j])
        if start > lst.window_end[j] + _EPS:
            ok = False
        if not ok and bad_out is not None and not bad_out:
            bad_out.append(len(out))
        out.append(start)
        ready = finish[j] = start + lst.duration[j]
        dist_row = lst.task_task_dist[j]
    return out, ok


def path_score(p: Problem, path: list[int], times: np.ndarray) -> float:
    if not path:
        return 0.0
    return float(task_scores(p, np.asarray(path), times).sum())


@dataclass(frozen=True)
class Evaluation:
    """A joint plan: start times per agent path, which tasks complete, and the total score."""

    start_times: tuple[tuple[float, ...], ...]  # per agent, aligned with its path
    completed: tuple[bool, ...]  # per task
    group: tuple[tuple[int, ...], ...]  # per task, the agents with it on their path
    task_start: tuple[float, ...]  # per task (nan when not completed)
    total_score: float


def execute_jointly(p: Problem, paths: Sequence[Sequence[int]],
                    per_agent_start: list[dict[int, float]] | None = None
                    ) -> tuple[list[list[int]], list[bool], list[float]]:
    """Execute the agents' paths jointly: (group, completed, start) per task.

    A task is usable when its whole group (L_j agents covering its equipment list) holds
    it. Its members start it together when all have arrived, not before the window opens
    and after its prerequisites have finished; one that cannot start in its window is
    skipped by its members. Agents waiting on each other in a cycle drop the lowest-index
    blocked task. A task's start is nan when it does not complete; `per_agent_start`, when
    given (one dict per agent), receives each agent's start of the tasks it completes.
    """
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
    start_of = [math.nan] * m
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
                        if per_agent_start is not None:
                            per_agent_start[k][j] = start
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
    return group, completed, start_of


def evaluate_plan(p: Problem, paths: list[list[int]]) -> Evaluation:
    """Execute the agents' paths jointly (`execute_jointly`). Every member of a completed
    task earns the task's score at the joint start time."""
    per_agent_start: list[dict[int, float]] = [{} for _ in paths]
    group, completed, start_of = execute_jointly(p, paths, per_agent_start)
    score = 0.0
    for j in range(p.n_tasks):
        if completed[j]:
            score += float(len(group[j])
                           * task_scores(p, np.array([j]), np.array([start_of[j]]))[0])
    starts = tuple(
        tuple(float(per_agent_start[i].get(j, np.nan)) for j in path)
        for i, path in enumerate(paths)
    )
    return Evaluation(
        start_times=starts,
        completed=tuple(completed),
        group=tuple(tuple(g) for g in group),
        task_start=tuple(start_of),
        total_score=score,
    )
