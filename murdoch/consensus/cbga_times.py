"""CBGA's group timing: when partners can be at a group task, the times an agent publishes,
and which late or crossed group task it gives up (see `murdoch.consensus.cbga`)."""

from __future__ import annotations

import math

from murdoch.consensus.cbga_state import CbgaState
from murdoch.consensus.scoring import path_starts


class CbgaTimes(CbgaState):
    """Phase 1's timing of group tasks (the paper's eq. 8, with paths)."""

    def partners_time(self, j: int) -> float:
        """The latest planned start of the other members of group task j (0 when none).

        A member that cannot itself be there inside the window is left out: it is the one
        that makes the group late, and it gives the task up (its own `refresh_times` finds
        its path infeasible). Only that member leaves; the punctual ones keep the task."""
        if self.single[j]:
            return 0.0
        cache = self._partners
        if cache is not None:
            hit = cache.get(j)
            if hit is not None:
                return hit
        i = self.index
        latest = self._latest[j]
        lb = 0.0
        trow = self.t[j]
        for m, v in enumerate(self.x[j]):
            if v > 0 and m != i:
                at = trow[m]
                if lb < at <= latest:
                    lb = at
        if cache is not None:
            cache[j] = lb
        return lb

    def not_before(self) -> list[float] | None:
        """`partners_time` of every task (None without group tasks)."""
        if not self.group_idx:
            return None
        return [self.partners_time(j) for j in range(self.problem.n_tasks)]

    def _lower_bounds(self, path: list[int]) -> dict[int, float] | None:
        if not self.group_idx:
            return None
        out = {}
        cache = self._partners
        single = self.single
        for j in path:
            if single[j]:
                continue
            lb = None if cache is None else cache.get(j)
            if lb is None:
                lb = self.partners_time(j)
            if lb > 0:
                out[j] = lb
        return out

    def _publish_times(self, ready: list[float] | None = None) -> None:
        """Record when this agent can be at each of its group tasks on its own (what its
        partners wait for); the group starts at the latest of its members' times. `ready`:
        those times along the current path when already known (`path_starts`' ready_out
        with the same lower bounds)."""
        if not self.group_idx:
            return
        i = self.index
        if ready is None:
            ready = []
            path_starts(self.problem, i, self.path, self._lower_bounds(self.path), ready)
        t = self.t
        for j in self.group_idx:
            t[j][i] = 0.0
        for j, at in zip(self.path, ready, strict=True):
            if not self.single[j]:
                t[j][i] = at

    def refresh_times(self) -> bool:
        """Re-plan start times against the partners' latest plans; drop a group task that
        can no longer start in its window. True if anything changed.

        Two members can wait on each other across two group tasks they hold in opposite
        orders (each late for one task because it waits for the other at another). Ties go
        to the higher agent index: a member made late by waiting for a lower-index partner
        keeps its plan for one round so that the partner, made late by waiting for it,
        gives its task up first; if the plan is still infeasible a round later it drops."""
        if not self.group_idx or not self.active:
            return False
        dropped = self._drop_crossed_orders()
        held = False
        while True:
            bad: list[int] = []
            ready: list[float] = []
            times, ok = path_starts(self.problem, self.index, self.path,
                                    self._lower_bounds(self.path), ready, bad)
            if ok:
                break
            j = self.path[bad[0]]
            blamed = self._blamed_partner(bad[0])
            if blamed is not None and blamed < self.index and not self.yielding.get(j):
                self.yielding = {j: True}
                held = True
                break
            self.x[j][self.index] = 0.0
            self.bundle.remove(j)
            self.path = [q for q in self.path if q != j]
            dropped = True
        if not held:
            self.yielding = {}
        moved = dropped or times != self.times
        if moved:
            self._set_path(self.path, times)
        self._publish_times(ready)
        if moved:
            self.needs_build = True
        return moved

    def _crossed(self, path: list[int]) -> dict[int, set[int]]:
        """Group tasks of `path` planned in the opposite order to a higher-index partner: if
        both hold g and h, this agent doing g first and the partner h first (its own times
        say so), each would wait for the other. Returns the later task of each such pair
        and the partners it crosses."""
        i = self.index
        shared = [j for j in path if not self.single[j]]
        later: dict[int, set[int]] = {}
        if len(shared) < 2:
            return later
        x, t = self.x, self.t
        n = self.problem.n_agents
        for a, g in enumerate(shared):
            if g in later:
                continue
            xg, tg = x[g], t[g]
            for h in shared[a + 1:]:
                if h in later:
                    continue
                xh, th = x[h], t[h]
                partners = {m for m in range(i + 1, n)
                            if xg[m] > 0 and xh[m] > 0 and tg[m] > 0 and th[m] > 0
                            and th[m] < tg[m]}
                if partners:
                    later[h] = partners
        return later

    def _drop_crossed_orders(self) -> bool:
        """Ties go to the higher index: of a pair of group tasks planned in the opposite
        order to a higher-index partner, this agent drops the later one and does not rejoin
        it while any partner it crossed is still in that group (several lower-index
        members may give way at once, so the group's other members are not a reliable
        sign that anything changed); True if it dropped any."""
        i = self.index
        drop = self._crossed(self.path)
        for j, partners in drop.items():
            self.yielded[j] = frozenset(partners)
            self.x[j][i] = 0.0
            self.bundle.remove(j)
        if drop:
            self._set_path([q for q in self.path if q not in drop], self.times)
        return bool(drop)

    def _blamed_partner(self, bad: int) -> int | None:
        """The partner this agent last waited for on a group task before path[bad] (None
        when it waited for nobody there)."""
        if not self.group_idx:
            return None
        ready: list[float] = []
        path_starts(self.problem, self.index, self.path[:bad], self._lower_bounds(self.path),
                    ready)
        for n in range(bad - 1, -1, -1):
            g = self.path[n]
            if not self.single[g] and self.partners_time(g) > ready[n]:
                best, who = -math.inf, 0
                for m, (v, at) in enumerate(zip(self.x[g], self.t[g], strict=True)):
                    if v > 0 and m != self.index and at > best:
                        best, who = at, m
                return who
        return None
