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
from itertools import compress
from operator import itemgetter, ne, or_

from murdoch.consensus.cbba import (
    merge_timestamps,
    message_stamps,
)
from murdoch.consensus.cbga_rows import CbgaRows
from murdoch.consensus.cbga_state import (
    TEAM_MODES,
    CbgaOptions,
    Matrix,
    team_bound_bonus,
    zeros,
)
from murdoch.consensus.conflict import NONE
from murdoch.consensus.messages import KIND_CBGA, ConsensusMessage
from murdoch.consensus.scoring import Problem, path_starts

__all__ = ["TEAM_MODES", "CbgaAgent", "CbgaOptions", "Matrix", "team_bound_bonus", "zeros"]


class CbgaAgent(CbgaRows):
    """One CBGA agent: its state (`CbgaState`), group timing (`CbgaTimes`), bundle building
    (phase 1) and consensus on X, T and the timestamps (phase 2)."""

    kind = KIND_CBGA

    # -- phase 1 ------------------------------------------------------------------------
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
        forced, order = self._bid_order(cands, held, cap, known_bounds)
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

    def _bid_order(self, cands: list[tuple[int, float, float, bool, float]], held: set[int],
                   cap: float, known_bounds: dict[int, tuple[float, float]]
                   ) -> tuple[list[tuple[float, int, float]], list[tuple[float, int, float]]]:
        """The tasks `_add_best` tries: group tasks with a pending yield (always), then the
        others by their bid's upper bound, highest first (as (-bound, task, not-before))."""
        blocked = self._blocked
        yielded = self.yielded
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
        return forced, order

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
