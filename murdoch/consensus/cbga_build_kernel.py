"""Phase 1 of the compiled CBGA run (`cbga_kernel.run_cbga`): bundle building over arrays.

An agent's group-task timing (partners' not-before times, start times along its path), the
choice of a group (`select_group`), completeness, group bids with equipment and team reward,
and `_build`, which adds tasks to an agent's bundle as `cbga.CbgaAgent.build_bundle` does,
with the same floating-point operations in the same order. The layout of the arrays is the
one `cbga_kernel` describes.

`cbga_kernel` compiles these functions into its run, and numba caches a compiled function by
its own file only, so `cbga_kernel.BUILD_SHA256` names the fingerprint of this file and
`test_consensus_kernel_parts.py` keeps it current.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.kernel_parts import (
    commit_path,
    gain,
    held_tasks,
    insert_task,
    path_starts,
    prepare,
    row_winner,
)

PARTS_SHA256 = "faf09f64dff8c2f95bf3bd53767118afd737e73822b364b9c8ad27114769815b"
"""The `kernel_parts.py` this module was written against (see its notes on numba's cache)."""


@njit(cache=True)
def _copy(dst: np.ndarray, src: np.ndarray) -> None:
    """dst[...] = src for (A, B, C) arrays of the same shape (plain loops compile faster than
    the broadcasting assignment)."""
    for a in range(src.shape[0]):
        for b in range(src.shape[1]):
            for c in range(src.shape[2]):
                dst[a, b, c] = src[a, b, c]


@njit(cache=True)
def _bits(v: int) -> int:
    c = 0
    while v:
        v &= v - 1
        c += 1
    return c


@njit(cache=True)
def _partners_time(i: int, j: int, xi: np.ndarray, ti: np.ndarray, latest: np.ndarray
                   ) -> float:
    """`CbgaAgent.partners_time` of group task j: the latest planned time of the other
    members that can themselves be there in the window (0 when none)."""
    lb = 0.0
    lat = latest[j]
    for q in range(xi.shape[1]):
        if xi[j, q] > 0.0 and q != i:
            at = ti[j, q]
            if lb < at and at <= lat:
                lb = at
    return lb


@njit(cache=True)
def _path_starts(i: int, xi: np.ndarray, ti: np.ndarray, single: np.ndarray,
                 latest: np.ndarray, groups: bool, at_row: np.ndarray, tt: np.ndarray,
                 tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float,
                 avail: float, path: np.ndarray, n_path: int, out: np.ndarray,
                 ready: np.ndarray) -> tuple[bool, int]:
    """`scoring.path_starts` with the group lower bounds of `CbgaAgent._lower_bounds`:
    start times (into `out`), each task's own time before the group bound (into `ready`),
    whether every start fits, and the first index that does not (-1)."""
    lower = np.zeros(tasks.shape[1])
    if groups:
        for n in range(n_path):
            j = path[n]
            if not single[j]:
                lower[j] = _partners_time(i, j, xi, ti, latest)
    return path_starts(at_row, tt, tasks, pre_ptr, pre_idx, speed, avail, path, n_path, lower,
                       out, ready)


@njit(cache=True)
def _publish(i: int, ti: np.ndarray, single: np.ndarray, path: np.ndarray, n_path: int,
             ready: np.ndarray) -> None:
    """`CbgaAgent._publish_times` (the caller checks that there are group tasks)."""
    for j in range(ti.shape[0]):
        if not single[j]:
            ti[j, i] = 0.0
    for n in range(n_path):
        j = path[n]
        if not single[j]:
            ti[j, i] = ready[n]


@njit(cache=True)
def _rank(vals: np.ndarray, order: np.ndarray) -> int:
    """The agents with a positive value, strongest first (equal values: the higher index
    first), into `order`; returns how many."""
    cnt = 0
    for q in range(vals.shape[0]):
        v = vals[q]
        if v > 0.0:
            # q is the highest index so far: it goes before equal values
            p = cnt
            while p > 0 and vals[order[p - 1]] <= v:
                order[p] = order[p - 1]
                p -= 1
            order[p] = q
            cnt += 1
    return cnt


@njit(cache=True)
def _select_group(vals: np.ndarray, size: int, need: int, agent_eq: np.ndarray,
                  order: np.ndarray, chosen: np.ndarray) -> None:
    """`CbgaAgent.select_group` over the candidates with a positive value: `chosen` marks
    the group kept."""
    for q in range(chosen.shape[0]):
        chosen[q] = False
    cnt = _rank(vals, order)
    if need == 0:
        for p in range(min(cnt, size)):
            chosen[order[p]] = True
        return
    taken = 0
    covered = 0
    for p in range(cnt):
        if taken >= size:
            break
        q = order[p]
        eq = agent_eq[q]
        if _bits(need & ~covered & ~eq) > size - taken - 1:
            continue
        chosen[q] = True
        taken += 1
        covered |= eq
    return


@njit(cache=True)
def _complete(j: int, xi: np.ndarray, required: np.ndarray, task_eq: np.ndarray,
              agent_eq: np.ndarray) -> bool:
    cnt = 0
    covered = 0
    for q in range(xi.shape[1]):
        if xi[j, q] > 0.0:
            cnt += 1
            covered |= agent_eq[q]
    if cnt < required[j]:
        return False
    return (task_eq[j] & ~covered) == 0


@njit(cache=True)
def _team_bound(ub: float, others: int) -> float:
    """`cbga.team_bound_bonus`: what team mode "total" can add to a bid bounded by ub."""
    if not ub > 0.0 or others <= 0:
        return 0.0
    return ub * others + 1e-9 * (1.0 + ub * (1 + others))


@njit(cache=True)
def _group_bid(i: int, j: int, xi: np.ndarray, gain: float, cap: float, team: bool,
               banned: np.ndarray, yielded: np.ndarray, yset: np.ndarray,
               required: np.ndarray, team_reward: np.ndarray, task_eq: np.ndarray,
               agent_eq: np.ndarray, vals: np.ndarray, order: np.ndarray,
               chosen: np.ndarray, drop: np.ndarray, team_total: bool) -> tuple[bool, float]:
    """`CbgaAgent._group_bid`: (valid, bid); `drop` marks the members it pushes out.
    Clears a yield once the partners it crossed have left the group."""
    n = xi.shape[1]
    for q in range(n):
        drop[q] = False
    n_members = 0
    for q in range(n):
        if xi[j, q] > 0.0 and q != i:
            n_members += 1
    if n_members <= banned[j]:
        return False, 0.0
    if yielded[j]:
        for q in range(n):
            if yset[j, q] and xi[j, q] > 0.0 and q != i:
                return False, 0.0
        yielded[j] = False
        for q in range(n):
            yset[j, q] = False
    size = required[j]
    bid = gain
    if team and size > 1 and team_total:
        if team_reward[j] > 0.0:
            others = min(n_members, size - 1)
            b2 = bid * float(1 + others)
            bid = b2 if b2 <= cap else cap
    elif team and size > 1:
        others = min(n_members, size - 1)
        b2 = bid + team_reward[j] * others / (size - 1)
        bid = b2 if b2 <= cap else cap
    if task_eq[j] == 0:
        if n_members < size:
            return True, bid
        stronger = 0
        for q in range(n):
            v = xi[j, q]
            if v > 0.0 and q != i and (v > bid or (v == bid and q > i)):
                stronger += 1
        if stronger >= size:
            return False, 0.0
        for q in range(n):
            vals[q] = xi[j, q] if q != i else 0.0
        cnt = _rank(vals, order)
        for p in range(size - 1, cnt):
            drop[order[p]] = True
        return True, bid
    for q in range(n):
        vals[q] = xi[j, q] if q != i else bid
    _select_group(vals, size, task_eq[j], agent_eq, order, chosen)
    if not chosen[i]:
        return False, 0.0
    for q in range(n):
        if q != i and xi[j, q] > 0.0 and not chosen[q]:
            drop[q] = True
    return True, bid


@njit(cache=True, inline="always")
def _candidates(i: int, xi: np.ndarray, ti: np.ndarray, held: np.ndarray, eligible: np.ndarray,
                bound: np.ndarray, single: np.ndarray, latest: np.ndarray, banned: np.ndarray,
                quits: np.ndarray, quit_limit: int, required: np.ndarray,
                team_reward: np.ndarray, team: bool, team_total: bool, cand_j: np.ndarray,
                cand_ub: np.ndarray, cand_nb: np.ndarray, cand_bonus: np.ndarray) -> int:
    """`CbgaAgent._build_candidates` (may lift bans): the tasks agent i may add, each with
    its bound, its partners' time and its team bonus; returns how many."""
    m, n = xi.shape
    n_cand = 0
    for j in range(m):
        if not eligible[j] or held[j]:
            continue
        ub = bound[j]
        bonus = 0.0
        nb = 0.0
        if single[j]:
            top = 0.0
            for q in range(n):
                if xi[j, q] > top:
                    top = xi[j, q]
            if ub < top:
                continue
        else:
            ban = banned[j]
            others = 0
            if ban >= 0 or team:
                for q in range(n):
                    if xi[j, q] != 0.0:
                        others += 1
                if xi[j, i] > 0.0:
                    others -= 1
                if others <= ban:
                    continue
                if ban >= 0 and quits[j] < quit_limit:
                    banned[j] = -1
            nb = _partners_time(i, j, xi, ti, latest)
            size = required[j]
            if team and size > 1 and team_total:
                if team_reward[j] > 0.0:
                    bonus = _team_bound(ub, min(others, size - 1))
            elif team and size > 1:
                bonus = team_reward[j] * min(others, size - 1) / (size - 1)
        cand_j[n_cand] = j
        cand_ub[n_cand] = ub
        cand_nb[n_cand] = nb
        cand_bonus[n_cand] = bonus
        n_cand += 1
    return n_cand


@njit(cache=True, inline="always")
def _order(n_cand: int, cand_j: np.ndarray, cand_ub: np.ndarray, cand_nb: np.ndarray,
           cand_bonus: np.ndarray, blocked: np.ndarray, held: np.ndarray,
           yielded: np.ndarray, single: np.ndarray, cap: float, ord_j: np.ndarray,
           ord_ub: np.ndarray, ord_nb: np.ndarray) -> tuple[int, int]:
    """The order of evaluation: yielded group tasks first (always evaluated, in task
    order), then the others by bound; returns (forced, all)."""
    n_forced = 0
    for c in range(n_cand):
        j = cand_j[c]
        if blocked[j] or held[j]:
            continue
        if yielded[j] and not single[j]:
            ord_j[n_forced] = j
            ord_nb[n_forced] = cand_nb[c]
            ord_ub[n_forced] = 0.0
            n_forced += 1
    n_ord = n_forced
    for c in range(n_cand):
        j = cand_j[c]
        if blocked[j] or held[j] or (yielded[j] and not single[j]):
            continue
        ub = cand_ub[c]
        if cand_bonus[c] != 0.0:
            ub += cand_bonus[c]
        if cap < ub:
            ub = cap
        if ub > 0.0:
            p = n_ord  # after every higher or equal bound (equal: lower index first)
            while p > n_forced and ord_ub[p - 1] < ub:
                ord_ub[p] = ord_ub[p - 1]
                ord_j[p] = ord_j[p - 1]
                ord_nb[p] = ord_nb[p - 1]
                p -= 1
            ord_ub[p] = ub
            ord_j[p] = j
            ord_nb[p] = cand_nb[c]
            n_ord += 1
    return n_forced, n_ord


@njit(cache=True, inline="always")
def _outbid_group(j: int, ub: float, xi: np.ndarray, required: np.ndarray) -> bool:
    """An equipment-free group task whose every seat is held by a bid above `ub`."""
    n = xi.shape[1]
    above = ub + 1e-9 * (1.0 + ub)
    top = 0.0
    cnt = 0
    for q in range(n):
        v = xi[j, q]
        if v > top:
            top = v
        if v > above:
            cnt += 1
    return top > above and cnt >= required[j]


@njit(cache=True, inline="always")
def _single_bid(i: int, j: int, g: float, xi: np.ndarray, drop: np.ndarray) -> tuple[bool, float]:
    """Agent i's bid g on single-agent task j: valid if it beats the winner it knows (a tie
    goes to the lower index)."""
    n = xi.shape[1]
    yj, zj = row_winner(xi[j])
    if not (g > yj or (g == yj and zj >= i)):
        return False, 0.0
    for q in range(n):
        drop[q] = False
    return True, g


@njit(cache=True, inline="always")
def _commit(i: int, j: int, bid: float, now: float, best_pos: int, n_path: int,
            xi: np.ndarray, ti: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
            path: np.ndarray, times: np.ndarray, plen: np.ndarray, assigned_at: np.ndarray,
            gain_ok: np.ndarray, held: np.ndarray, single: np.ndarray, groups: bool,
            new_path: np.ndarray, new_times: np.ndarray, new_ready: np.ndarray,
            best_drop: np.ndarray) -> None:
    """Take task j at `best_pos` with `bid`: the timed path becomes agent i's, the bundle
    grows, the partners it drops lose their bids."""
    n = xi.shape[1]
    commit_path(i, j, n_path, new_path, new_times, path, times, plen, gain_ok, bundle, blen,
                held)
    if groups:
        _publish(i, ti, single, path, n_path + 1, new_ready)
    for q in range(n):
        if best_drop[q]:
            xi[j, q] = 0.0
    if single[j]:
        for q in range(n):
            xi[j, q] = 0.0
    xi[j, i] = bid
    assigned_at[j] = now


@njit(cache=True)
def _build(i: int, now: float, xi: np.ndarray, ti: np.ndarray, bundle: np.ndarray,
           blen: np.ndarray, path: np.ndarray, times: np.ndarray, plen: np.ndarray,
           assigned_at: np.ndarray, banned: np.ndarray, quits: np.ndarray,
           yielded: np.ndarray, yset: np.ndarray, gain_val: np.ndarray, gain_pos: np.ndarray,
           gain_nb: np.ndarray, gain_ok: np.ndarray, at_row: np.ndarray, tt: np.ndarray,
           tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float,
           avail: float, eligible: np.ndarray, bound: np.ndarray, single: np.ndarray,
           latest: np.ndarray, groups: bool, required: np.ndarray, team_reward: np.ndarray,
           task_eq: np.ndarray, agent_eq: np.ndarray, team: bool, quit_limit: int,
           max_depth: int, work: np.ndarray, team_total: bool) -> None:
    """Agent i's bundle building (`BundleBuilding.build_bundle` with
    `CbgaAgent._add_best`); the arrays are agent i's rows."""
    m, n = xi.shape
    blocked = np.zeros(m, dtype=np.bool_)
    held = held_tasks(i, bundle, blen, m)
    cand_j = np.zeros(m, dtype=np.int64)
    cand_ub = np.zeros(m)
    cand_nb = np.zeros(m)
    cand_bonus = np.zeros(m)
    n_cand = -1  # candidates are worked out at the first step
    ord_j = np.zeros(m, dtype=np.int64)
    ord_ub = np.zeros(m)
    ord_nb = np.zeros(m)
    new_path = np.zeros(m + 1, dtype=np.int64)
    new_times = np.zeros(m + 1)
    new_ready = np.zeros(m + 1)
    pos_of = np.zeros(m, dtype=np.int64)
    vals = np.zeros(n)
    order = np.zeros(n, dtype=np.int64)
    chosen = np.zeros(n, dtype=np.bool_)
    drop = np.zeros(n, dtype=np.bool_)
    best_drop = np.zeros(n, dtype=np.bool_)
    while blen[i] < max_depth:
        if n_cand < 0:
            n_cand = _candidates(i, xi, ti, held, eligible, bound, single, latest, banned,
                                 quits, quit_limit, required, team_reward, team, team_total,
                                 cand_j, cand_ub, cand_nb, cand_bonus)
        n_path = plen[i]
        late = prepare(at_row, tt, tasks, speed, avail, path, times, n_path, work, pos_of)
        cap = xi[bundle[blen[i] - 1], i] if blen[i] > 0 else math.inf
        n_forced, n_ord = _order(n_cand, cand_j, cand_ub, cand_nb, cand_bonus, blocked, held,
                                 yielded, single, cap, ord_j, ord_ub, ord_nb)
        best = -math.inf
        best_j = -1
        best_pos = 0
        for o in range(n_ord):
            j = ord_j[o]
            nb = ord_nb[o]
            if o >= n_forced:
                ub = ord_ub[o]
                if ub < best:
                    break
                if ub == best and j > best_j:
                    continue
                if task_eq[j] == 0 and not single[j] and _outbid_group(j, ub, xi, required):
                    continue
            if gain_ok[j] and gain_nb[j] == nb:
                g = gain_val[j]
                pos = gain_pos[j]
            else:
                g, pos = gain(j, nb, at_row, tt, tasks, pre_ptr, pre_idx, speed, path,
                               times, n_path, late, work, pos_of)
                gain_val[j] = g
                gain_pos[j] = pos
                gain_nb[j] = nb
                gain_ok[j] = True
            if not g > 0.0:
                continue
            if g > cap:
                g = cap
            if single[j]:
                valid, bid = _single_bid(i, j, g, xi, drop)
            else:
                valid, bid = _group_bid(i, j, xi, g, cap, team, banned, yielded, yset,
                                        required, team_reward, task_eq, agent_eq, vals,
                                        order, chosen, drop, team_total)
            if not valid:
                continue
            if bid > best or (bid == best and j < best_j):
                best = bid
                best_j = j
                best_pos = pos
                for q in range(n):
                    best_drop[q] = drop[q]
        if best_j < 0:
            return
        j = best_j
        # `CbgaAgent._insert`: the path with j at best_pos, timed against the partners
        insert_task(path, n_path, best_pos, j, new_path)
        ok, _bad = _path_starts(i, xi, ti, single, latest, groups, at_row, tt, tasks, pre_ptr,
                                pre_idx, speed, avail, new_path, n_path + 1, new_times,
                                new_ready)
        if not ok:
            blocked[j] = True
            continue
        _commit(i, j, best, now, best_pos, n_path, xi, ti, bundle, blen, path, times, plen,
                assigned_at, gain_ok, held, single, groups, new_path, new_times, new_ready,
                best_drop)
