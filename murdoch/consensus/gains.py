"""Marginal gains of inserting a task into one agent's path, in plain Python, cached per path.

`PathGains` holds one agent's path (tasks in execution order and their start times) and
evaluates, on demand, the best gain of inserting a task at any position of it. What does
not depend on the inserted task (the idle time before each path task, how late each may
still start, each task's current score) is computed once per path; a task's result is
cached until the path changes, so an agent whose path stayed the same re-uses its bids and
only tasks it has not looked at yet cost anything. Problems here are small (tens of tasks,
short paths): plain loops beat array operations whose call overhead dominates.

Inserting task c before path position q delays the task there by ``d0`` (when positive);
each later task's delay shrinks by the idle time the agent had before it, so a suffix walk
stops at the first task that absorbs the delay. The insertion is feasible when c starts
inside its window and no delayed task starts after its latest start.

Each evaluation also leaves an upper bound of the task's gain that holds on every path grown
from this one by insertions (`upper_bound`), which bundle building hands from a path to the
next so that it can skip tasks that cannot win.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from murdoch.consensus.scoring import _EPS, LINEAR_MARGIN, Problem, task_value

_NEG_INF = -math.inf
_ROBUST_S = 1e-6  # an infeasibility by more than this is not a rounding effect


class _PathColumns(NamedTuple):
    """What `PathGains` computes once per path, by path position q (rows and ready have one
    more entry, for the end of the path)."""

    rows: list[list[float]]
    """Distances to every task from where the agent is before position q."""
    ready: list[float]
    """When the agent is free to leave for position q."""
    cum: list[float]
    """The agent's idle time before the path's tasks, summed through the task at q."""
    old: list[float]
    """The score of the task at q at its current start."""
    lam: list[float]
    """The discount of the task at q."""
    room: list[float]
    """How much later the task at q may still start."""


class PathGains:
    """Best insertion gain and position of any task into one fixed path (cached per task)."""

    __slots__ = (
        "_cache",
        "_columns",
        "_late",
        "_linear",
        "_p",
        "_speed",
        "bounds_known",
        "path",
        "pos_of",
        "times",
    )

    def __init__(self, p: Problem, agent: int, path: list[int], times: list[float],
                 bounds: dict[int, tuple[float, float]] | None = None) -> None:
        lst = p.lists
        self._p = p
        self.path = path
        self.times = times
        self.pos_of = {j: n for n, j in enumerate(path)}
        speed = lst.speed[agent]
        self._speed = speed
        # rows[q]: distances from where the agent is before path position q
        rows = [lst.agent_task_dist[agent]]
        ready = [lst.availability[agent]]
        cum: list[float] = []
        old: list[float] = []
        lam: list[float] = []
        room: list[float] = []
        total_wait = 0.0
        for n, j in enumerate(path):
            t = times[n]
            wait = t - (ready[n] + rows[n][j] / speed)
            total_wait += wait if wait > 0.0 else 0.0
            cum.append(total_wait)
            disc = lst.discount[j]
            old.append(task_value(lst, j, t))
            lam.append(disc)
            room.append(lst.window_end[j] - t + _EPS)
            ready.append(t + lst.duration[j])
            rows.append(lst.task_task_dist[j])
        self._columns = _PathColumns(rows, ready, cum, old, lam, room)
        # a path task already past its latest start makes every delaying insertion late
        self._late = any(r < 0.0 for r in room)
        # the paper's cost: a linear score, so a delay d costs exactly d (see `_evaluate`)
        self._linear = lst.linear
        self._cache: dict[int, tuple[float, float, int]] = {}
        # per task, no insertion gains more (see `upper_bound`)
        # task -> (its not-before time, the bound)
        self.bounds_known: dict[int, tuple[float, float]] = {} if bounds is None else bounds

    def gain(self, c: int, not_before: float = 0.0) -> tuple[float, int]:
        """(best marginal gain, its position) of inserting task c; (-inf, 0) when no
        insertion is feasible. Ties between positions go to the earliest."""
        hit = self._cache.get(c)
        if hit is not None and hit[0] == not_before:
            return hit[1], hit[2]
        best, at, floor, miss = self._evaluate(c, not_before)
        self._cache[c] = (not_before, best, at)
        if not self._p.prereqs[c] or floor > _NEG_INF:
            if best == _NEG_INF and miss > _ROBUST_S:
                self.bounds_known[c] = (not_before, _NEG_INF)
            else:
                self.bounds_known[c] = (not_before, self._bound_from(c, floor))
        return best, at

    def upper_bound(self, c: int, not_before: float = 0.0) -> float:
        """No insertion of c (with this not-before time) gains more, on this path or on any
        path grown from it by insertions; inf when unknown.

        A task's own score falls with its start (exponentially, or linearly with the
        paper's cost), delays of the path's tasks only cost,
        and an insertion never lets a task start earlier than it could before: the
        positions before it are unchanged, the one right after it is reached through it
        (triangle inequality) and the later ones start no earlier. So the earliest start
        found on an ancestor path (less a rounding margin) bounds the gain. For the same
        reason every start on a grown path is no earlier than at the matching insertion
        on the ancestor, so an insertion that was infeasible on the ancestor by more than
        a rounding margin (a start after a latest start) stays infeasible: -inf."""
        hit = self.bounds_known.get(c)
        return hit[1] if hit is not None and hit[0] == not_before else math.inf

    def bounds(self) -> dict[int, tuple[float, float]]:
        """The upper bounds known so far, to hand to a path grown from this one."""
        return dict(self.bounds_known)

    def _bound_from(self, c: int, floor: float) -> float:
        lst = self._p.lists
        disc = lst.discount[c]
        if disc < 0.0 and not lst.linear:
            return math.inf
        start = floor - 1e-9 * (1.0 + abs(floor))
        if start > lst.window_end[c] + _EPS:
            return _NEG_INF
        if start < lst.window_start[c]:
            start = lst.window_start[c]
        own = task_value(lst, c, start)
        if lst.linear:
            # additive: a relative margin would lower a negative bound
            return own + LINEAR_MARGIN * (1.0 + abs(own))
        return own * (1.0 + 1e-9)

    def _evaluate(self, c: int, not_before: float) -> tuple[float, int, float, float]:
        """(gain, position, earliest start at any position, smallest margin by which an
        infeasible position missed; 0 when one missed for another reason)."""
        p = self._p
        times = self.times
        ws, we, dur, ref, reward, disc = p.lists.task_params[c]
        speed = self._speed
        rows, ready, cum, old, lam, room = self._columns
        n_path = len(times)
        late = self._late
        linear = self._linear
        exp, expm1 = math.exp, math.expm1
        lower = not_before
        first = 0
        pre = p.prereqs[c]
        if pre:
            pos_of = self.pos_of
            if not all(q in pos_of for q in pre):
                return _NEG_INF, 0, _NEG_INF, 0.0
            first = max(pos_of[q] for q in pre) + 1
            duration = p.lists.duration
            lower = max(lower, max(times[pos_of[q]] + duration[q] for q in pre))
        best = _NEG_INF
        at = 0
        floor = math.inf  # earliest start at any position
        miss = math.inf
        for q in range(first, n_path + 1):
            r = ready[q]
            if r > we:
                if r < floor:
                    floor = r
                if r - we < miss:
                    miss = r - we
                break  # ready times only grow along the path
            start = r + rows[q][c] / speed
            if start < ws:
                start = ws
            if start < lower:
                start = lower
            if start < floor:
                floor = start
            if start > we:
                if start - we < miss:
                    miss = start - we
                continue
            if linear:
                total = reward - dur - (start - ref)
            else:
                total = reward * exp(-disc * (start - ref))
            if total <= best:
                continue  # delays only lower it further
            if q < n_path:
                # the task now at q is delayed by d0; each later one by d0 less the idle
                # time before it, until a task absorbs the delay
                d0 = start + dur + rows[q + 1][c] / speed - times[q]
                if d0 > 0.0:
                    if late:
                        miss = 0.0
                        continue
                    if d0 > room[q]:
                        if d0 - room[q] < miss:
                            miss = d0 - room[q]
                        continue
                    if linear:
                        change = -d0
                    else:
                        change = old[q] * expm1(-lam[q] * d0)
                    base = cum[q]
                    feasible = True
                    for k in range(q + 1, n_path):
                        delay = d0 - (cum[k] - base)
                        if delay <= 0.0:
                            break
                        if delay > room[k]:
                            feasible = False
                            if delay - room[k] < miss:
                                miss = delay - room[k]
                            break
                        if linear:
                            change -= delay
                        else:
                            change += old[k] * expm1(-lam[k] * delay)
                    if not feasible:
                        continue
                    total += change
            if total > best:
                best = total
                at = q
        return best, at, floor, miss


def insertion_gains(p: Problem, agent: int, path: list[int], times: list[float],
                    candidates: list[bool], not_before: list[float] | None = None
                    ) -> tuple[list[float], list[int]]:
    """Gain and position of inserting each candidate task (non-candidates: -inf, 0)."""
    pg = PathGains(p, agent, path, times)
    gains = [_NEG_INF] * p.n_tasks
    pos = [0] * p.n_tasks
    for c, want in enumerate(candidates):
        if want:
            gains[c], pos[c] = pg.gain(c, 0.0 if not_before is None else not_before[c])
    return gains, pos
