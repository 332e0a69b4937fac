"""CBGA (Hunt, Meng, Hinde & Huang 2014): consensus on tasks that need groups of agents.

Each agent keeps a winning-bid matrix X (tasks x agents): X[j, m] is the bid agent m made for
task j as this agent believes it, 0 when m is not assigned. A task j needs L_j agents whose
equipment together covers the task's list. Rows with L_j = 1 are resolved exactly as CBBA
does (the row's single non-zero entry is y_j and z_j), so on scenarios without group tasks
CBGA gives CBBA's result.

Group rows follow the paper's Algorithm 2. First the receiver refreshes the members it
believes in from the sender when the sender heard from that member more recently (or is that
member). Then it adds the sender's other members it has fresher news of, and keeps the group
`select_group` picks: strongest bids first (equal bids: the higher agent index first), each
taken while there is room and the group can still cover the task's equipment. For agents
carrying one item each this is the paper's rule (a newcomer replaces only the weakest member
with the same equipment, and only with a higher bid); being a function of the candidates, it
also lets two views of the same candidates agree when agents carry several items.

Bundle construction is Algorithm 1: a group task is a valid choice when `select_group` would
keep this agent in it (room left, or outbidding the weakest replaceable member).

Group members wait for each other (the paper's eq. 8, with paths instead of straight lines):
each agent also keeps T[j, m], the time member m can be at group task j on its own, sends it
with its bids, and plans its own start on j no earlier than the latest of its partners'.
A group task that can no longer start in its window after a partner's news is dropped, by
the member that makes the group late only (a partner already past the window is not waited
for). Deadlock-free tie handling, ties to the higher agent index: of two group tasks a pair
of members plan in opposite orders, the lower-index member gives up the later one (see
`refresh_times`).

Options: task quitting (leave a group task still incomplete `quit_after` rounds after joining
it, and do not rejoin until more agents have joined) and team reward (a group-task bid adds
``team_reward * others / (L_j - 1)`` for the others already in it). Prerequisites must be on
the agent's own path before the dependent task. Bids are warped as in CBBA (never above the
bid of the task added before).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from murdoch.consensus.cbba import (
    BundleBuilding,
    merge_timestamps,
    message_stamps,
    new_timestamps,
)
from murdoch.consensus.conflict import NONE, apply_actions, resolve_many
from murdoch.consensus.messages import KIND_CBGA, ConsensusMessage
from murdoch.consensus.scoring import _EPS, Problem, path_times


@dataclass(frozen=True)
class CbgaOptions:
    task_quitting: bool = True
    team_reward: bool = True


class CbgaAgent(BundleBuilding):
    """One agent's CBGA state: X (M, N), timestamps, bundle, path, quit bookkeeping."""

    kind = KIND_CBGA

    def __init__(self, problem: Problem, index: int, options: CbgaOptions | None = None,
                 x: np.ndarray | None = None, s: np.ndarray | None = None,
                 t: np.ndarray | None = None) -> None:
        self.problem = problem
        self.index = index
        self.options = options or CbgaOptions()
        self.x = np.zeros((problem.n_tasks, problem.n_agents)) if x is None else x
        self.s = new_timestamps(problem.n_agents) if s is None else s
        # when each believed member can be at each group task on its own (0 = unknown)
        self.t = np.zeros((problem.n_tasks, problem.n_agents)) if t is None else t
        self.bundle: list[int] = []
        self.path: list[int] = []
        self.times = np.zeros(0)
        self.assigned_at = np.full(problem.n_tasks, np.nan)
        self.banned = np.full(problem.n_tasks, -1, dtype=np.int64)
        self.yielding: dict[int, bool] = {}  # a late group task kept one round (see below)
        # group tasks given up to a higher-index partner -> the other members then
        self.yielded: dict[int, frozenset[int]] = {}
        self.needs_build = True
        self.active = True
        self._refresh_static()

    def _refresh_static(self) -> None:
        p = self.problem
        self.single = p.required == 1
        self.single_idx = np.flatnonzero(self.single)
        self.group_idx = np.flatnonzero(~self.single)

    # -- equipment ----------------------------------------------------------------------
    def select_group(self, j: int, bids: dict[int, float]) -> list[int]:
        """The group task j keeps from candidate (agent -> bid) pairs: strongest first (equal
        bids: higher agent index first), each taken while the group has room and can still
        cover the task's equipment with one new item per remaining place. With agents that
        carry one item each this keeps the paper's rule: a newcomer replaces only the
        weakest member with the same equipment, and only with a higher bid."""
        p = self.problem
        need = p.task_equipment[j]
        size = int(p.required[j])
        chosen: list[int] = []
        covered: set[str] = set()
        for m in sorted(bids, key=lambda m: (-bids[m], -m)):
            if len(chosen) >= size:
                break
            eq = p.agent_equipment[m]
            if need and len(need - covered - eq) > size - len(chosen) - 1:
                continue
            chosen.append(m)
            covered |= eq
        return chosen

    def complete(self, j: int) -> bool:
        members = np.flatnonzero(self.x[j] > 0)
        if len(members) < self.problem.required[j]:
            return False
        covered: set[str] = set()
        for m in members:
            covered |= self.problem.agent_equipment[m]
        return self.problem.task_equipment[j] <= covered

    # -- phase 1 ------------------------------------------------------------------------
    def candidates(self) -> np.ndarray | None:
        if len(self.bundle) >= self.problem.max_depth:
            return None
        p = self.problem
        cand = p.eligible[self.index] & ~self._blocked
        if self.single_idx.size:
            rows = self.single_idx
            cand[rows] &= p.gain_bound[self.index, rows] >= self.x[rows].max(axis=1)
        cand[self.bundle] = False
        return cand if cand.any() else None

    def not_before(self) -> np.ndarray | None:
        """Per task, the latest planned start of the other members of its group.

        A member that cannot itself be there inside the window is left out: it is the one
        that makes the group late, and it gives the task up (its own `refresh_times` finds
        its path infeasible). Only that member leaves; the punctual ones keep the task."""
        if not self.group_idx.size:
            return None
        others = self.x > 0
        others[:, self.index] = False
        others &= self.t <= self.problem.window_end[:, None] + _EPS
        lb = np.where(others, self.t, 0.0).max(axis=1)
        lb[self.single_idx] = 0.0
        return lb

    def _lower_bounds(self, path: list[int]) -> dict[int, float] | None:
        if not self.group_idx.size:
            return None
        lb = self.not_before()
        assert lb is not None
        return {j: float(lb[j]) for j in path if not self.single[j] and lb[j] > 0}

    def _publish_times(self) -> None:
        """Record when this agent can be at each of its group tasks on its own (what its
        partners wait for); the group starts at the latest of its members' times."""
        if not self.group_idx.size:
            return
        i = self.index
        ready: list[float] = []
        path_times(self.problem, i, self.path, self._lower_bounds(self.path), ready)
        self.t[self.group_idx, i] = 0.0
        for j, at in zip(self.path, ready, strict=True):
            if not self.single[j]:
                self.t[j, i] = at

    def refresh_times(self) -> bool:
        """Re-plan start times against the partners' latest plans; drop a group task that
        can no longer start in its window. True if anything changed.

        Two members can wait on each other across two group tasks they hold in opposite
        orders (each late for one task because it waits for the other at another). Ties go
        to the higher agent index: a member made late by waiting for a lower-index partner
        keeps its plan for one round so that the partner, made late by waiting for it,
        gives its task up first; if the plan is still infeasible a round later it drops."""
        if not self.group_idx.size or not self.active:
            return False
        dropped = self._drop_crossed_orders()
        held = False
        while True:
            times, ok = path_times(self.problem, self.index, self.path,
                                   self._lower_bounds(self.path))
            if ok:
                break
            bad = self._first_infeasible()
            j = self.path[bad]
            blamed = self._blamed_partner(bad)
            if blamed is not None and blamed < self.index and not self.yielding.get(j):
                self.yielding = {j: True}
                held = True
                break
            self.x[j, self.index] = 0.0
            self.bundle.remove(j)
            self.path.remove(j)
            dropped = True
        if not held:
            self.yielding = {}
        moved = dropped or times.shape != self.times.shape or bool((times != self.times).any())
        self.times = times
        self._publish_times()
        if moved:
            self.needs_build = True
        return moved

    def _crossed(self, path: list[int]) -> set[int]:
        """Group tasks of `path` planned in the opposite order to a higher-index partner: if
        both hold g and h, this agent doing g first and the partner h first (its own times
        say so), each would wait for the other. Returns the later task of each such pair."""
        i = self.index
        shared = [j for j in path if not self.single[j]]
        if len(shared) < 2:
            return set()
        x, t = self.x, self.t
        later: set[int] = set()
        for a, g in enumerate(shared):
            if g in later:
                continue
            for h in shared[a + 1:]:
                if h in later:
                    continue
                both = (x[g] > 0) & (x[h] > 0) & (t[g] > 0) & (t[h] > 0)
                both[: i + 1] = False
                if (both & (t[h] < t[g])).any():
                    later.add(h)
        return later

    def _drop_crossed_orders(self) -> bool:
        """Ties go to the higher index: of a pair of group tasks planned in the opposite
        order to a higher-index partner, this agent drops the later one and does not rejoin
        it while the other members stay the same; True if it dropped any."""
        i = self.index
        drop = self._crossed(self.path)
        for j in drop:
            self.yielded[j] = frozenset(int(m) for m in np.flatnonzero(self.x[j] > 0) if m != i)
            self.x[j, i] = 0.0
            self.bundle.remove(j)
            self.path.remove(j)
        return bool(drop)

    def _first_infeasible(self) -> int:
        for n in range(1, len(self.path) + 1):
            prefix = self.path[:n]
            if not path_times(self.problem, self.index, prefix, self._lower_bounds(prefix))[1]:
                return n - 1
        return len(self.path) - 1

    def _blamed_partner(self, bad: int) -> int | None:
        """The partner this agent last waited for on a group task before path[bad] (None
        when it waited for nobody there)."""
        lb = self.not_before()
        if lb is None:
            return None
        ready: list[float] = []
        path_times(self.problem, self.index, self.path[:bad], self._lower_bounds(self.path),
                   ready)
        for n in range(bad - 1, -1, -1):
            g = self.path[n]
            if not self.single[g] and lb[g] > ready[n]:
                row = np.where(self.x[g] > 0, self.t[g], -np.inf)
                row[self.index] = -np.inf
                return int(np.argmax(row))
        return None

    def take(self, gains: np.ndarray, pos: np.ndarray, now: float) -> bool:
        p, i = self.problem, self.index
        cand = gains > 0
        if not cand.any():
            return False
        cap = self.x[self.bundle[-1], i] if self.bundle else np.inf
        gains = np.minimum(gains, cap)
        bids = gains.copy()
        valid = np.zeros(p.n_tasks, dtype=bool)
        replace: dict[int, list[int]] = {}
        if self.single_idx.size:
            xs = self.x[self.single_idx]
            y = xs.max(axis=1)
            z = np.where(y > 0, xs.argmax(axis=1), NONE)
            g = gains[self.single_idx]
            valid[self.single_idx] = cand[self.single_idx] & (
                (g > y) | ((g == y) & ((z > i) | (z == i))))
        group = self.group_idx[cand[self.group_idx]].tolist()
        rows = self.x[group].tolist() if group else []
        gains_l = gains.tolist()
        for j, row in zip(group, rows, strict=True):
            members = {m: v for m, v in enumerate(row) if v > 0 and m != i}
            if self.banned[j] >= 0:
                if len(members) <= self.banned[j]:
                    continue
                self.banned[j] = -1
            if j in self.yielded:
                if self.yielded[j] == members.keys():
                    continue
                del self.yielded[j]
            size = int(p.required[j])
            bid = gains_l[j]
            if self.options.team_reward and size > 1:
                others = min(len(members), size - 1)
                bid = min(bid + p.team_reward[j] * others / (size - 1), cap)
            chosen = self.select_group(j, {**members, i: bid})
            if i not in chosen:
                continue
            bids[j] = bid
            valid[j] = True
            dropped = [m for m in members if m not in chosen]
            if dropped:
                replace[j] = dropped
        if not valid.any():
            return False
        j = int(np.argmax(np.where(valid, bids, -np.inf)))
        if not self._insert(j, int(pos[j])):
            self._blocked[j] = True
            return True
        for m in replace.get(j, ()):
            self.x[j, m] = 0.0
        if self.single[j]:
            self.x[j, :] = 0.0
        self.x[j, i] = bids[j]
        self.assigned_at[j] = now
        return True

    @staticmethod
    def take_many(agents: Sequence[CbgaAgent], gains: np.ndarray, pos: np.ndarray,
                  now: float) -> list[bool]:
        return [a.take(gains[n], pos[n], now) for n, a in enumerate(agents)]

    def _insert(self, j: int, position: int) -> bool:
        path = [*self.path[:position], j, *self.path[position:]]
        times, ok = path_times(self.problem, self.index, path, self._lower_bounds(path))
        if not ok:
            return False
        self.path = path
        self.times = times
        self.bundle.append(j)
        self._publish_times()
        return True

    # -- phase 2 ------------------------------------------------------------------------
    def message(self, now: float) -> ConsensusMessage:
        s = self.s[:-1].copy()
        s[self.index] = now
        js, ms = np.nonzero(self.x)
        starts = tuple((int(j), int(m), float(self.t[j, m]))
                       for j, m in zip(js, ms, strict=True)
                       if not self.single[j] and self.t[j, m] > 0)
        return ConsensusMessage(
            self.kind, self.index, float(now),
            tuple((int(j), int(m), float(self.x[j, m])) for j, m in zip(js, ms, strict=True)),
            tuple(float(v) for v in s), starts)

    def receive(self, msg: ConsensusMessage, now: float,
                tasks: tuple[int, int] | None = None, merge: bool = True) -> bool:
        """Apply one neighbour's message, or its part covering tasks [first, end)."""
        if not self.active or msg.sender == self.index:
            return False
        p = self.problem
        s_k = message_stamps(msg, self.s.size)
        if s_k is None:
            return False
        x_k = np.zeros((p.n_tasks, p.n_agents))
        for j, m, b in msg.entries:
            if 0 <= j < p.n_tasks and 0 <= m < p.n_agents and b > 0:
                x_k[j, m] = b
        t_k = np.zeros((p.n_tasks, p.n_agents))
        for j, m, start in msg.starts:
            if 0 <= j < p.n_tasks and 0 <= m < p.n_agents:
                t_k[j, m] = start
        rows = None
        if tasks is not None:
            rows = np.zeros(p.n_tasks, dtype=bool)
            rows[tasks[0]:tasks[1]] = True
        return self.receive_arrays(msg.sender, x_k, s_k, now, rows, merge, t_k)

    def merge_stamps(self, msg: ConsensusMessage, now: float) -> None:
        s_k = message_stamps(msg, self.s.size)
        if s_k is not None and msg.sender != self.index:
            merge_timestamps(self.s, s_k, self.index, msg.sender, now)

    def receive_arrays(self, k: int, x_k: np.ndarray, s_k: np.ndarray, now: float,
                       rows: np.ndarray | None = None, merge: bool = True,
                       t_k: np.ndarray | None = None) -> bool:
        """Merge sender k's matrix and timestamps (s_k[k] must be the send time), for the
        task rows selected by `rows` (all when None)."""
        i = self.index
        x_i = self.x
        changed = False
        single_idx, group_idx = self.single_idx, self.group_idx
        if rows is not None:
            single_idx = single_idx[rows[single_idx]]
            group_idx = group_idx[rows[group_idx]]
        if single_idx.size:
            rows = single_idx
            xs_i, xs_k = x_i[rows], x_k[rows]
            differ = (xs_i != xs_k).any(axis=1)
            if differ.any():
                rows = rows[differ]
                xs_i, xs_k = xs_i[differ], xs_k[differ]
                y_i = xs_i.max(axis=1)
                z_i = np.where(y_i > 0, xs_i.argmax(axis=1), NONE)
                y_k = xs_k.max(axis=1)
                z_k = np.where(y_k > 0, xs_k.argmax(axis=1), NONE)
                y_new, z_new = y_i[None, :].copy(), z_i[None, :].copy()
                actions = resolve_many(np.array([i]), np.array([k]), y_k[None, :],
                                       z_k[None, :], y_new, z_new, s_k[None, :],
                                       self.s[None, :])
                apply_actions(actions, y_new, z_new, y_k[None, :], z_k[None, :])
                moved = (y_new[0] != y_i) | (z_new[0] != z_i)
                for r, y, z in zip(rows[moved], y_new[0][moved], z_new[0][moved], strict=True):
                    x_i[r, :] = 0.0
                    if z != NONE:
                        x_i[r, z] = y
                changed = bool(moved.any())
        if group_idx.size:
            t_k = np.zeros_like(x_k) if t_k is None else t_k
            # Algorithm 2 only takes from the sender what it knows better (members it heard
            # from more recently, or itself) and never this agent's own entry; a row that
            # differs in nothing else cannot change (non-members' times are always 0).
            fresher_a = s_k[:-1] > self.s[:-1]
            fresher_a[k] = True
            fresher_a[i] = False
            differ = group_idx[(((x_i[group_idx] != x_k[group_idx])
                                 | (self.t[group_idx] != t_k[group_idx]))
                                & fresher_a).any(axis=1)]
            if differ.size:
                fresher = (s_k[:-1] > self.s[:-1]).tolist()
                fresher[k] = True
                for j in differ.tolist():
                    changed |= self._merge_group_row(j, k, x_k[j].tolist(), fresher,
                                                     t_k[j].tolist())
        if merge:
            merge_timestamps(self.s, s_k, i, k, now)
        if changed:
            self.needs_build = True
        return changed

    def _merge_group_row(self, j: int, k: int, row_k: list[float], fresher: list[bool],
                         starts_k: list[float]) -> bool:
        """Algorithm 2 for one group row (plain Python lists: rows are short).
        `fresher[m]` says the sender knows member m better (m is the sender, or the sender
        heard from m more recently)."""
        i = self.index
        n = len(row_k)
        before = self.x[j].tolist()
        starts_before = self.t[j].tolist()
        row = list(before)
        starts = list(starts_before)
        # phase 1: refresh what we believe from a sender who knows better
        for m in range(n):
            if row[m] > 0 and m != i and fresher[m]:
                row[m] = row_k[m]
        # phase 2: add the sender's other members, then keep the group select_group picks
        bids = {m: row[m] for m in range(n) if row[m] > 0}
        fresh = False
        for m in range(n):
            if row_k[m] > 0 and m != i and m not in bids and fresher[m]:
                bids[m] = row_k[m]
                fresh = True
        if fresh or row != before:
            chosen = self.select_group(j, bids)
            row = [0.0] * n
            for m in chosen:
                row[m] = bids[m]
        # planned times follow whoever knows the member better
        for m in range(n):
            if row[m] > 0:
                if m != i and row_k[m] == row[m] and fresher[m]:
                    starts[m] = starts_k[m]
            elif m != i:
                starts[m] = 0.0
        changed = row != before or starts != starts_before
        if changed:
            self.x[j] = row
            self.t[j] = starts
        return changed

    # -- releases -----------------------------------------------------------------------
    def release_outbid(self) -> bool:
        i = self.index
        for n, j in enumerate(self.bundle):
            if self.x[j, i] <= 0:
                self._release_from(n, keep_first=True)
                return True
        return False

    def quit_stalled(self, now: float) -> bool:
        """Task quitting: leave the first group task still incomplete after its threshold."""
        if not self.options.task_quitting or not self.active:
            return False
        p = self.problem
        for j in self.bundle:
            if self.single[j] or not np.isfinite(p.quit_after[j]):
                continue
            if now - self.assigned_at[j] >= p.quit_after[j] and not self.complete(j):
                others = int((self.x[j] > 0).sum()) - 1
                self.x[j, self.index] = 0.0
                self.bundle.remove(j)
                self.path.remove(j)
                self.times, _ = path_times(p, self.index, self.path,
                                           self._lower_bounds(self.path))
                self._publish_times()
                self.banned[j] = max(others, 0)
                self.needs_build = True
                return True
        return False

    def next_quit_time(self) -> float:
        """When a pending quit would happen (inf when none is pending)."""
        if not self.options.task_quitting or not self.active:
            return np.inf
        p = self.problem
        best = np.inf
        for j in self.bundle:
            if (not self.single[j] and np.isfinite(p.quit_after[j])
                    and not self.complete(j)):
                best = min(best, float(self.assigned_at[j] + p.quit_after[j]))
        return best

    def _release_from(self, n: int, keep_first: bool) -> None:
        i = self.index
        released = self.bundle[n:]
        later = released[1:] if keep_first else released
        for j in later:
            if self.single[j]:
                self.x[j, :] = 0.0
            else:
                self.x[j, i] = 0.0
        self.bundle = self.bundle[:n]
        drop = set(released)
        self.path = [j for j in self.path if j not in drop]
        self.times, _ = path_times(self.problem, i, self.path, self._lower_bounds(self.path))
        self._publish_times()
        self.needs_build = True

    def forget_agent(self, gone: int) -> None:
        if (self.x[:, gone] > 0).any():
            self.x[:, gone] = 0.0
            self.t[:, gone] = 0.0
            self.needs_build = True

    def winners_view(self) -> list[frozenset[int]]:
        return [frozenset(int(m) for m in np.flatnonzero(r > 0)) for r in self.x]
