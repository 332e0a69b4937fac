"""CBGA (Hunt, Meng, Hinde & Huang 2014): consensus on tasks that need groups of agents.

Each agent keeps a winning-bid matrix X (tasks x agents, a list of rows): X[j][m] is the bid
agent m made for task j as this agent believes it, 0 when m is not assigned. A task j needs
L_j agents whose equipment together covers the task's list. Rows with L_j = 1 are resolved
exactly as CBBA does (the row's single non-zero entry is y_j and z_j), so on scenarios
without group tasks CBGA gives CBBA's result.

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
each agent also keeps T[j][m], the time member m can be at group task j on its own, sends it
with its bids, and plans its own start on j no earlier than the latest of its partners'.
A group task that can no longer start in its window after a partner's news is dropped, by
the member that makes the group late only (a partner already past the window is not waited
for). Deadlock-free tie handling, ties to the higher agent index: of two group tasks a pair
of members plan in opposite orders, the lower-index member gives up the later one and
stays out of it while that partner is in the group (see `refresh_times`).

Options: task quitting (leave a group task still incomplete `quit_after` rounds after joining
it, do not rejoin until more agents have joined, and give the task up for good after
`quit_limit` quits of it, so that quitting ends) and team reward (a group-task bid adds
``team_reward * others / (L_j - 1)`` for the others already in it, or with team mode
"total" is the agent's gain times the members it completes with: itself and the others).
Prerequisites must be on the agent's own path before the dependent task. Bids are warped as
in CBBA (never above the bid of the task added before).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import compress
from operator import itemgetter, ne, or_

from murdoch.consensus.cbba import (
    BundleBuilding,
    merge_timestamps,
    message_stamps,
)
from murdoch.consensus.conflict import NONE, resolve_lists
from murdoch.consensus.messages import KIND_CBGA, ConsensusMessage
from murdoch.consensus.scoring import _EPS, Problem, path_starts

Matrix = list[list[float]]


def zeros(rows: int, cols: int) -> Matrix:
    return [[0.0] * cols for _ in range(rows)]


# how team reward enters a group-task bid (on tasks with a team_reward): "bonus" adds
# team_reward * others / (L_j - 1); "total" bids what the whole group earns, the agent's
# own gain for each member, itself and the others already in the group (the paper's "total
# value for a successful task rather than just their individual contribution")
TEAM_MODES = ("bonus", "total")


def team_bound_bonus(ub: float, others: int) -> float:
    """What the "total" team reward can add to a bid whose own gain is at most `ub`, with
    `others` already in the group (a rounding margin included); 0 when ub <= 0."""
    if not ub > 0.0 or others <= 0:
        return 0.0
    return ub * others + 1e-9 * (1.0 + ub * (1 + others))


@dataclass(frozen=True)
class CbgaOptions:
    task_quitting: bool = True
    team_reward: bool = True
    # an agent quits one group task at most this many times, then gives it up for the run
    quit_limit: int = 5
    team_mode: str = "bonus"  # one of TEAM_MODES


class CbgaAgent(BundleBuilding):
    """One agent's CBGA state: X (M x N), T (M x N), timestamps, bundle, path, quit
    bookkeeping (plain lists: the problems are small)."""

    kind = KIND_CBGA

    def __init__(self, problem: Problem, index: int, options: CbgaOptions | None = None
                 ) -> None:
        self._init_agent(problem, index)
        self.options = options or CbgaOptions()
        self.x = zeros(problem.n_tasks, problem.n_agents)
        # when each believed member can be at each group task on its own (0 = unknown)
        self.t = zeros(problem.n_tasks, problem.n_agents)
        self.assigned_at = [math.nan] * problem.n_tasks
        # task quitting: per task, the other members seen when this agent last quit it (it
        # stays out until the group is larger; -1 = no ban) and how often it quit it
        self.banned = [-1] * problem.n_tasks
        self.quits = [0] * problem.n_tasks
        self.yielding: dict[int, bool] = {}  # a late group task kept one round (see below)
        # group tasks given up to a higher-index partner -> the other members then
        self.yielded: dict[int, frozenset[int]] = {}
        self._partners: dict[int, float] | None = None
        self._candidates: list[tuple[int, float, float, bool, float]] | None = None
        self._refresh_static()

    def _refresh_static(self) -> None:
        p = self.problem
        self.single: list[bool] = [int(r) == 1 for r in p.required]
        self.single_idx = [j for j, one in enumerate(self.single) if one]
        self.group_idx = [j for j, one in enumerate(self.single) if not one]
        self._latest = [w + _EPS for w in p.lists.window_end]
        self._no_equipment = [not e for e in p.task_equipment]

    def state_key(self) -> tuple[tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...],
                                 tuple[int, ...]]:
        """What `comm_steps` watches: bids, group members' times and bundle."""
        return tuple(map(tuple, self.x)), tuple(map(tuple, self.t)), tuple(self.bundle)

    # -- equipment ----------------------------------------------------------------------
    def select_group(self, j: int, bids: dict[int, float]) -> list[int]:
        """The group task j keeps from candidate (agent -> bid) pairs: strongest first (equal
        bids: higher agent index first), each taken while the group has room and can still
        cover the task's equipment with one new item per remaining place. With agents that
        carry one item each this keeps the paper's rule: a newcomer replaces only the
        weakest member with the same equipment, and only with a higher bid."""
        p = self.problem
        need = p.task_equipment[j]
        size = p.lists.required[j]
        order = sorted(bids, key=lambda m: (-bids[m], -m))
        if not need:
            return order[:size]
        chosen: list[int] = []
        covered: set[str] = set()
        for m in order:
            if len(chosen) >= size:
                break
            eq = p.agent_equipment[m]
            if len(need - covered - eq) > size - len(chosen) - 1:
                continue
            chosen.append(m)
            covered |= eq
        return chosen

    def complete(self, j: int) -> bool:
        members = [m for m, v in enumerate(self.x[j]) if v > 0]
        if len(members) < self.problem.lists.required[j]:
            return False
        covered: set[str] = set()
        for m in members:
            covered |= self.problem.agent_equipment[m]
        return self.problem.task_equipment[j] <= covered

    # -- phase 1 ------------------------------------------------------------------------
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

    def build_bundle(self, now: float = 0.0) -> bool:
        # during a build only this agent's own entries and the row of the task it adds
        # change: partners' times and the candidate tasks are worked out once
        self._partners = {}
        try:
            return super().build_bundle(now)
        finally:
            self._partners = None
            self._candidates = None

    def _build_candidates(self) -> list[tuple[int, float, float, bool, float]]:
        """The tasks this agent may bid on in this build, each with (task, static bound of
        its gain, not-before time, single-agent, team-reward bonus). The rows of tasks not
        in the bundle do not change during a build, so neither does any of this."""
        p, i = self.problem, self.index
        lst = p.lists
        banned = self.banned
        eligible = lst.eligible[i]
        bound = lst.gain_bound[i]
        single = self.single
        rows = self.x
        team = self.options.team_reward
        total = self.options.team_mode == "total"
        required, team_reward = lst.required, lst.team_reward
        held = set(self.bundle)  # (a bundle only grows during a build)
        out = []
        for j in range(p.n_tasks):
            if not eligible[j] or j in held:
                continue
            ub = bound[j]
            bonus = 0.0
            if single[j]:
                nb = 0.0
                if ub < max(rows[j]):
                    continue
            else:
                ban = banned[j]
                if ban >= 0 or team:
                    row = rows[j]  # (bids are positive; 0 = not in the group)
                    others = len(row) - row.count(0.0) - (row[i] > 0)
                    if others <= ban:
                        continue  # quit, and the group has not grown since
                    if ban >= 0 and self.quits[j] < self.options.quit_limit:
                        banned[j] = -1  # others have joined since this agent quit: bid again
                nb = self.partners_time(j)
                size = required[j]
                if team and size > 1 and total:
                    if team_reward[j] > 0.0:
                        bonus = team_bound_bonus(ub, min(others, size - 1))
                elif team and size > 1:
                    bonus = team_reward[j] * min(others, size - 1) / (size - 1)
            out.append((j, ub, nb, single[j], bonus))
        return out

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

    def _add_best(self, now: float) -> bool:
        """Algorithm 1, one step: insert the best task whose bid is valid (a single task
        outbidding its winner; a group task whose `select_group` keeps this agent); False
        when no valid bid remains (equal bids: the lower task index).

        Tasks are tried in the order of an upper bound of their bid, and the search stops
        at the first bound below the best valid bid found; a group task with a pending
        yield is always evaluated, since evaluating it may lift the yield. A task this
        agent quit is not tried while its group is no larger than the ban allows."""
        i = self.index
        held = set(self.bundle)
        blocked = self._blocked
        yielded = self.yielded
        single = self.single
        rows = self.x
        required = self.problem.lists.required
        gains = self.path_gains()
        known_bounds = gains.bounds_known
        partners = self._partners
        cands = self._candidates
        if cands is None:
            cands = self._build_candidates()
            if partners is not None:  # (inside a build: kept until it ends)
                self._candidates = cands
        cap = rows[self.bundle[-1]][i] if self.bundle else math.inf
        team = self.options.team_reward
        forced: list[tuple[float, int, float]] = []
        order: list[tuple[float, int, float]] = []
        for j, ub, nb, one, bonus in cands:
            if blocked[j] or j in held:
                continue
            if yielded and not one and j in yielded:
                forced.append((0.0, j, nb))
                continue
            hit = known_bounds.get(j)  # `PathGains.upper_bound`, inlined
            if hit is not None and hit[0] == nb and hit[1] < ub:
                ub = hit[1]
            if bonus:
                ub += bonus
            if cap < ub:
                ub = cap
            if ub > 0.0:
                order.append((-ub, j, nb))
        order.sort()
        best = -math.inf
        best_j = -1
        best_pos = 0
        replace: list[int] = []
        plain = self._no_equipment
        for neg_ub, j, nb in forced + order if forced else order:
            if neg_ub:  # (forced ones carry 0)
                ub = -neg_ub
                if ub < best:
                    break
                if ub == best and j > best_j:
                    continue
                row = rows[j]
                if plain[j] and not single[j]:
                    # a full group whose members all outbid even the bound keeps them (with
                    # a margin: the bounds may fall short of a bid by a rounding error)
                    above = ub + 1e-9 * (1.0 + ub)
                    if max(row) > above and sum(1 for v in row if v > above) >= required[j]:
                        continue
            g, pos = gains.gain(j, nb)
            if not g > 0.0:
                continue
            if g > cap:
                g = cap
            row = rows[j]
            dropped: list[int] = []
            if single[j]:
                yj = max(row)
                zj = row.index(yj) if yj > 0 else NONE
                if not (g > yj or (g == yj and zj >= i)):
                    continue
                bid = g
            else:
                maybe, dropped = self._group_bid(j, row, g, cap, team)
                if maybe is None:
                    continue
                bid = maybe
            if bid > best or (bid == best and j < best_j):
                best, best_j, best_pos, replace = bid, j, pos, dropped
        if best_j < 0:
            return False
        j = best_j
        if not self._insert(j, best_pos):
            blocked[j] = True
            return True
        row = rows[j]
        for m in replace:
            row[m] = 0.0
        if replace:
            # a partner pushed out may have been the one j waited for: j can start earlier
            # on the next path, so the bounds of this one do not carry over
            self._bounds = None
        if single[j]:
            row[:] = [0.0] * len(row)
        row[i] = best
        self.assigned_at[j] = now
        if partners is not None:
            partners.pop(j, None)
        return True

    def _group_bid(self, j: int, row: list[float], gain: float, cap: float, team: bool
                   ) -> tuple[float | None, list[int]]:
        """This agent's bid on group task j if `select_group` would keep it (else None),
        and the members it would push out. Clears a yield once the partners it crossed
        have left the group."""
        i = self.index
        members = [m for m, v in enumerate(row) if v > 0 and m != i]
        if len(members) <= self.banned[j]:
            return None, []  # (a build's candidates already leave these out)
        if j in self.yielded:
            if self.yielded[j].intersection(members):
                return None, []
            del self.yielded[j]
        lst = self.problem.lists
        size = lst.required[j]
        bid = gain
        if team and size > 1 and self.options.team_mode == "total":
            if lst.team_reward[j] > 0.0:
                others = min(len(members), size - 1)
                bid = min(bid * float(1 + others), cap)
        elif team and size > 1:
            others = min(len(members), size - 1)
            bid = min(bid + lst.team_reward[j] * others / (size - 1), cap)
        if not self.problem.task_equipment[j]:
            if len(members) < size:
                return bid, []  # room left and nothing to cover: select_group keeps everyone
            # select_group without equipment: the `size` strongest (equal bids: the higher
            # index first) stay
            stronger = 0
            for m in members:
                v = row[m]
                if v > bid or (v == bid and m > i):
                    stronger += 1
            if stronger >= size:
                return None, []
            ranked = sorted(members, key=lambda m: (-row[m], -m))
            kept = set(ranked[:size - 1])
            return bid, [m for m in members if m not in kept]
        bids = {m: row[m] for m in members}
        bids[i] = bid
        chosen = self.select_group(j, bids)
        if i not in chosen:
            return None, []
        return bid, [m for m in members if m not in chosen]

    def _insert(self, j: int, position: int) -> bool:
        path = [*self.path[:position], j, *self.path[position:]]
        ready: list[float] = []
        times, ok = path_starts(self.problem, self.index, path, self._lower_bounds(path),
                                ready)
        if not ok:
            return False
        self._set_path(path, times, grown=True)
        self.bundle.append(j)
        self._publish_times(ready)
        return True

    # -- phase 2 ------------------------------------------------------------------------
    def sent_counts(self) -> tuple[int, int]:
        """What `message` would carry: (non-zero bids, members' planned times)."""
        n = self.problem.n_agents
        x, t = self.x, self.t
        entries = n * len(x) - sum(row.count(0.0) for row in x)
        starts = 0
        for j in self.group_idx:
            trow = t[j]
            if trow.count(0.0) == n:
                continue
            row = x[j]
            for m, at in enumerate(trow):
                if at > 0 and row[m] > 0:
                    starts += 1
        return entries, starts

    def sent_data(self) -> tuple[tuple[tuple[int, int, float], ...],
                                 tuple[tuple[int, int, float], ...]]:
        """The allocation data `message` carries: its entries and members' times."""
        entries = []
        starts = []
        single = self.single
        for j, (row, trow) in enumerate(zip(self.x, self.t, strict=True)):
            for m, v in enumerate(row):
                if v != 0:
                    entries.append((j, m, v))
                    if not single[j] and trow[m] > 0:
                        starts.append((j, m, trow[m]))
        return tuple(entries), tuple(starts)

    def message(self, now: float) -> ConsensusMessage:
        s = self.s[:-1]
        s[self.index] = now
        entries = []
        starts = []
        for j, (row, trow) in enumerate(zip(self.x, self.t, strict=True)):
            for m, v in enumerate(row):
                if v != 0:
                    entries.append((j, m, v))
                    if not self.single[j] and trow[m] > 0:
                        starts.append((j, m, trow[m]))
        return ConsensusMessage(self.kind, self.index, float(now), tuple(entries), tuple(s),
                                tuple(starts))

    def receive(self, msg: ConsensusMessage, now: float,
                tasks: tuple[int, int] | None = None, merge: bool = True) -> bool:
        """Apply one neighbour's message, or its part covering tasks [first, end)."""
        if not self.active or msg.sender == self.index:
            return False
        p = self.problem
        s_k = message_stamps(msg, len(self.s))
        if s_k is None:
            return False
        x_k = zeros(p.n_tasks, p.n_agents)
        for j, m, b in msg.entries:
            if 0 <= j < p.n_tasks and 0 <= m < p.n_agents and b > 0:
                x_k[j][m] = b
        t_k = zeros(p.n_tasks, p.n_agents)
        for j, m, start in msg.starts:
            if 0 <= j < p.n_tasks and 0 <= m < p.n_agents:
                t_k[j][m] = start
        first, end = (0, p.n_tasks) if tasks is None else tasks
        return self.receive_rows(msg.sender, x_k, t_k, s_k, now, first, end, merge)

    def merge_stamps(self, msg: ConsensusMessage, now: float) -> None:
        s_k = message_stamps(msg, len(self.s))
        if s_k is not None and msg.sender != self.index:
            merge_timestamps(self.s, s_k, self.index, msg.sender, now)

    def receive_rows(self, k: int, x_k: Matrix, t_k: Matrix, s_k: list[float], now: float,
                     first: int = 0, end: int | None = None, merge: bool = True) -> bool:
        """Merge sender k's X, T and timestamps (s_k[k] must be the send time) for the
        task rows [first, end); True if X or T changed. A changed row is replaced by a new
        list, never changed in place, and no row of the sender's is kept (so a snapshot of
        the row lists, not of the rows, holds what an agent sent this round)."""
        i = self.index
        x_i, t_i = self.x, self.t
        stop = len(x_i) if end is None else end
        single = self.single
        changed = False
        singles: list[int] = []
        groups: list[int] = []
        if x_i == x_k and t_i == t_k:
            rows: list[int] = []  # nothing to merge: only the timestamps move
        elif first == 0 and stop == len(x_i):
            rows = list(compress(range(stop), map(or_, map(ne, x_i, x_k), map(ne, t_i, t_k))))
        else:
            rows = [j for j in range(first, stop) if x_i[j] != x_k[j] or t_i[j] != t_k[j]]
        for j in rows:  # (single-agent rows have no times)
            if single[j]:
                singles.append(j)
            else:
                groups.append(j)
        if singles:
            changed = self._merge_single_rows(k, singles, x_k, s_k)
        if groups:
            # Algorithm 2 only takes from the sender what it knows better (members it heard
            # from more recently, or itself) and never this agent's own entry; a row that
            # differs in nothing else cannot change (non-members' times are always 0).
            s_i = self.s
            known = [m for m in range(len(s_i) - 1)
                     if m != i and (m == k or s_k[m] > s_i[m])]
            if known:
                pick = itemgetter(*known)
                for j in groups:
                    xk, tk = x_k[j], t_k[j]
                    if pick(x_i[j]) != pick(xk) or pick(t_i[j]) != pick(tk):
                        changed |= self._merge_group_row(j, xk, known, tk)
        if merge:
            merge_timestamps(self.s, s_k, i, k, now)
        if changed:
            self.needs_build = True
        return changed

    def _merge_single_rows(self, k: int, rows: list[int], x_k: Matrix,
                           s_k: list[float]) -> bool:
        """CBBA's rules on single-agent rows (a row's one non-zero entry is y_j, z_j)."""
        m_tasks = self.problem.n_tasks
        y_i, y_k = [0.0] * m_tasks, [0.0] * m_tasks
        z_i, z_k = [NONE] * m_tasks, [NONE] * m_tasks
        for j in rows:
            ri, rk = self.x[j], x_k[j]
            y_i[j] = max(ri)
            z_i[j] = ri.index(y_i[j]) if y_i[j] > 0 else NONE
            y_k[j] = max(rk)
            z_k[j] = rk.index(y_k[j]) if y_k[j] > 0 else NONE
        y_new, z_new = list(y_i), list(z_i)
        if not resolve_lists(self.index, k, y_new, z_new, self.s, y_k, z_k, s_k):
            return False
        for j in rows:
            if y_new[j] != y_i[j] or z_new[j] != z_i[j]:
                row = [0.0] * len(self.x[j])
                if z_new[j] != NONE:
                    row[z_new[j]] = y_new[j]
                self.x[j] = row
        return True

    def _merge_group_row(self, j: int, row_k: list[float], known: list[int],
                         starts_k: list[float]) -> bool:
        """Algorithm 2 for one group row. `known` lists the members the sender knows
        better than this agent (the sender itself, and those it heard from more recently);
        this agent's own entry is never taken from a sender."""
        before = self.x[j]
        row = list(before)
        # phase 1: refresh what we believe from a sender who knows better; phase 2: add
        # the sender's other members, then keep the group select_group picks. Both take
        # the sender's entry for every member it knows better (bids are positive, 0 = not
        # in the group), so the candidates are the row with those entries replaced.
        for m in known:
            row[m] = row_k[m]
        if row != before:
            size = self.problem.lists.required[j]
            if not self._no_equipment[j]:
                bids = {m: v for m, v in enumerate(row) if v > 0}
                row = [0.0] * len(row)
                for m in self.select_group(j, bids):
                    row[m] = bids[m]
            elif size < len(row) - row.count(0.0):
                # select_group without equipment: the `size` strongest stay
                ranked = sorted([m for m, v in enumerate(row) if v > 0],
                                key=lambda m: (-row[m], -m))
                for m in ranked[size:]:
                    row[m] = 0.0
            # (otherwise select_group keeps every candidate: the row stands)
        # planned times follow whoever knows the member better; non-members have none
        starts_before = self.t[j]
        starts = [a if v > 0 else 0.0 for v, a in zip(row, starts_before, strict=True)]
        i = self.index
        starts[i] = starts_before[i]
        for m in known:
            v = row[m]
            if v > 0 and row_k[m] == v:
                starts[m] = starts_k[m]
        changed = row != before or starts != starts_before
        if changed:
            self.x[j] = row
            self.t[j] = starts
        return changed

    # -- releases -----------------------------------------------------------------------
    def release_outbid(self) -> bool:
        i = self.index
        for n, j in enumerate(self.bundle):
            if self.x[j][i] <= 0:
                self._release_from(n, keep_first=True)
                return True
        return False

    def quit_stalled(self, now: float) -> bool:
        """Task quitting: leave the first group task still incomplete after its threshold.

        The agent then stays out of the task until it sees more agents in the group than
        when it left (the paper's "until other agents assign themselves"). News of a
        larger group can be stale: two pairs holding two stalled tasks quit in the same
        round, each sees the other pair's task as partly filled and joins it, and the pairs
        swap tasks for ever; agents that quit can also outbid members of another group,
        whose displaced members join the emptied task and later quit it in turn. So an
        agent quits one task at most `quit_limit` times and then gives it up for the rest
        of the run: quits are finite, and once they stop the run is plain CBGA."""
        if not self.options.task_quitting or not self.active:
            return False
        p = self.problem
        for j in self.bundle:
            if self.single[j] or not math.isfinite(p.quit_after[j]):
                continue
            if now - self.assigned_at[j] >= p.quit_after[j] and not self.complete(j):
                others = sum(1 for v in self.x[j] if v > 0) - 1
                self.x[j][self.index] = 0.0
                self.bundle.remove(j)
                path = [q for q in self.path if q != j]
                self._set_path(path, path_starts(p, self.index, path,
                                                 self._lower_bounds(path))[0])
                self._publish_times()
                # stay out until more agents are there than now; after `quit_limit` quits
                # of j, for good (so quitting ends: see `quit_stalled`)
                self.quits[j] += 1
                limit = self.options.quit_limit
                self.banned[j] = max(others, 0) if self.quits[j] < limit else p.n_agents
                self.needs_build = True
                return True
        return False

    def next_quit_time(self) -> float:
        """When a pending quit would happen (inf when none is pending)."""
        if not self.options.task_quitting or not self.active:
            return math.inf
        p = self.problem
        best = math.inf
        for j in self.bundle:
            if (not self.single[j] and math.isfinite(p.quit_after[j])
                    and not self.complete(j)):
                best = min(best, float(self.assigned_at[j] + p.quit_after[j]))
        return best

    def _release_from(self, n: int, keep_first: bool) -> None:
        i = self.index
        released = self.bundle[n:]
        later = released[1:] if keep_first else released
        for j in later:
            if self.single[j]:
                self.x[j] = [0.0] * len(self.x[j])
            else:
                self.x[j][i] = 0.0
        self.bundle = self.bundle[:n]
        drop = set(released)
        path = [j for j in self.path if j not in drop]
        self._set_path(path, path_starts(self.problem, i, path, self._lower_bounds(path))[0])
        self._publish_times()
        self.needs_build = True

    def add_tasks(self, problem: Problem) -> None:
        """The problem grew by new tasks (appended): no bids on them yet."""
        extra = problem.n_tasks - self.problem.n_tasks
        self.problem = problem
        self.x.extend(zeros(extra, problem.n_agents))
        self.t.extend(zeros(extra, problem.n_agents))
        self.assigned_at.extend([math.nan] * extra)
        self.banned.extend([-1] * extra)
        self.quits.extend([0] * extra)
        self._refresh_static()
        self._forget_paths()
        self.needs_build = True

    def forget_agent(self, gone: int) -> None:
        if any(row[gone] > 0 for row in self.x):
            for row, trow in zip(self.x, self.t, strict=True):
                row[gone] = 0.0
                trow[gone] = 0.0
            self.needs_build = True

    def winners_view(self) -> list[frozenset[int]]:
        return [frozenset(m for m, v in enumerate(row) if v > 0) for row in self.x]
