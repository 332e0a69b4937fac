"""Phase 1 of the compiled CBGA run: an agent's bundle building (`BundleBuilding.build_bundle`
with `CbgaAgent._add_best`: candidates, their order, group bids, insertion; see `cbga_kernel`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.cbga_kernel_parts import (
    _partners_time,
    _path_starts,
    _publish,
    _rank,
    _select_group,
)
from murdoch.consensus.kernel_parts import NONE, gain, prepare

SOURCES_SHA256 = {
    "kernel_parts.py": "48acf80e0cde01c59b7422d086ad54ef9789e4fcdad8d5835d7b9ab48604f2af",
    "cbga_kernel_parts.py": "9ee7999199310d41f4d0269c6e20003f088cdaf282abee0f13f2fc072f4afa38",
}
"""The kernel files this module's compiled code was built from (see `kernel_parts`)."""


@njit(cache=True)
def _group_bid(i: int, j: int, xi: np.ndarray, gain: float, cap: float, team: bool,
               banned: np.ndarray, yielded: np.ndarray, yset: np.ndarray,
               required: np.ndarray, team_reward: np.ndarray, task_eq: np.ndarray,
               agent_eq: np.ndarray, vals: np.ndarray, order: np.ndarray,
               chosen: np.ndarray, drop: np.ndarray) -> tuple[bool, float]:
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
    if team and size > 1:
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


@njit(cache=True)
def _candidates(i: int, xi: np.ndarray, ti: np.ndarray, held: np.ndarray,
                eligible: np.ndarray, bound: np.ndarray, single: np.ndarray,
                banned: np.ndarray, quits: np.ndarray, latest: np.ndarray,
                required: np.ndarray, team_reward: np.ndarray, team: bool, quit_limit: int,
                cand_j: np.ndarray, cand_ub: np.ndarray, cand_nb: np.ndarray,
                cand_bonus: np.ndarray) -> int:
    """`CbgaAgent._build_candidates` (may lift bans): each candidate task with its bound,
    not-before time and team bonus, in task order; their number."""
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
            if team and size > 1:
                bonus = team_reward[j] * min(others, size - 1) / (size - 1)
        cand_j[n_cand] = j
        cand_ub[n_cand] = ub
        cand_nb[n_cand] = nb
        cand_bonus[n_cand] = bonus
        n_cand += 1
    return n_cand


@njit(cache=True)
def _order(n_cand: int, cand_j: np.ndarray, cand_ub: np.ndarray, cand_nb: np.ndarray,
           cand_bonus: np.ndarray, blocked: np.ndarray, held: np.ndarray,
           yielded: np.ndarray, single: np.ndarray, cap: float, ord_j: np.ndarray,
           ord_ub: np.ndarray, ord_nb: np.ndarray) -> tuple[int, int]:
    """The order `_build` tries the candidates in: yielded group tasks first (always
    evaluated, in task order), then by bound, highest first (equal: lower index first);
    returns (how many are forced, how many in all)."""
    n_forced = 0
    n_ord = 0
    for c in range(n_cand):
        j = cand_j[c]
        if blocked[j] or held[j]:
            continue
        if yielded[j] and not single[j]:
            ord_j[n_forced] = j  # (forced ones fill the front, in task order)
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


@njit(cache=True)
def _full_above(row: np.ndarray, ub: float, size: int) -> bool:
    """A full group whose members all outbid even the bound `ub` keeps them (with a margin:
    the bounds may fall short of a bid by a rounding error)."""
    above = ub + 1e-9 * (1.0 + ub)
    top = 0.0
    cnt = 0
    for q in range(row.shape[0]):
        v = row[q]
        if v > top:
            top = v
        if v > above:
            cnt += 1
    return top > above and cnt >= size


@njit(cache=True)
def _outbids(i: int, g: float, row: np.ndarray) -> bool:
    """Whether agent i's bid `g` beats the single task's winner in `row` (equal bids: the
    lower agent index wins)."""
    yj = 0.0
    zj = NONE
    for q in range(row.shape[0]):
        if row[q] > yj:
            yj = row[q]
            zj = q
    return g > yj or (g == yj and zj >= i)


@njit(cache=True)
def _insert(i: int, j: int, best: float, best_pos: int, now: float, xi: np.ndarray,
            ti: np.ndarray, bundle: np.ndarray, blen: np.ndarray, path: np.ndarray,
            times: np.ndarray, plen: np.ndarray, assigned_at: np.ndarray, gain_ok: np.ndarray,
            best_drop: np.ndarray, single: np.ndarray, latest: np.ndarray, groups: bool,
            at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
            pre_idx: np.ndarray, speed: float, avail: float, new_path: np.ndarray,
            new_times: np.ndarray, new_ready: np.ndarray) -> bool:
    """`CbgaAgent._insert`: the path with j at best_pos, timed against the partners; False
    (nothing changed) when it does not fit, else j joins the bundle with bid `best`."""
    m, n = xi.shape
    n_path = plen[i]
    for q in range(best_pos):
        new_path[q] = path[q]
    new_path[best_pos] = j
    for q in range(best_pos, n_path):
        new_path[q + 1] = path[q]
    ok, _bad = _path_starts(i, xi, ti, single, latest, groups, at_row, tt, tasks, pre_ptr,
                            pre_idx, speed, avail, new_path, n_path + 1, new_times, new_ready)
    if not ok:
        return False
    for q in range(n_path + 1):
        path[q] = new_path[q]
        times[q] = new_times[q]
    plen[i] = n_path + 1
    for q in range(m):
        gain_ok[q] = False
    bundle[blen[i]] = j
    blen[i] += 1
    if groups:
        _publish(i, ti, single, path, n_path + 1, new_ready)
    for q in range(n):
        if best_drop[q]:
            xi[j, q] = 0.0
    if single[j]:
        for q in range(n):
            xi[j, q] = 0.0
    xi[j, i] = best
    assigned_at[j] = now
    return True


@njit(cache=True)
def _kept_gain(j: int, nb: float, gain_val: np.ndarray, gain_pos: np.ndarray,
               gain_nb: np.ndarray, gain_ok: np.ndarray, at_row: np.ndarray, tt: np.ndarray,
               tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float,
               path: np.ndarray, times: np.ndarray, n_path: int, late: bool,
               work: np.ndarray, pos_of: np.ndarray) -> tuple[float, int]:
    """The gain of inserting task j starting no earlier than nb: kept from before while the
    path has not changed and nb is the same, else computed (and kept)."""
    if gain_ok[j] and gain_nb[j] == nb:
        return gain_val[j], gain_pos[j]
    g, pos = gain(j, nb, at_row, tt, tasks, pre_ptr, pre_idx, speed, path, times, n_path,
                  late, work, pos_of)
    gain_val[j] = g
    gain_pos[j] = pos
    gain_nb[j] = nb
    gain_ok[j] = True
    return g, pos


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
           max_depth: int, work: np.ndarray) -> None:
    """Agent i's bundle building (`BundleBuilding.build_bundle` with
    `CbgaAgent._add_best`); the arrays are agent i's rows."""
    m, n = xi.shape
    blocked = np.zeros(m, dtype=np.bool_)
    held = np.zeros(m, dtype=np.bool_)
    for b in range(blen[i]):
        held[bundle[b]] = True
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
        if n_cand < 0:  # `CbgaAgent._build_candidates` (may lift bans)
            n_cand = _candidates(i, xi, ti, held, eligible, bound, single, banned, quits,
                                 latest, required, team_reward, team, quit_limit, cand_j,
                                 cand_ub, cand_nb, cand_bonus)
        n_path = plen[i]
        late = prepare(at_row, tt, tasks, speed, avail, path, times, n_path, work, pos_of)
        cap = xi[bundle[blen[i] - 1], i] if blen[i] > 0 else math.inf
        # the order: yielded group tasks first (always evaluated), then by bound
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
                if task_eq[j] == 0 and not single[j] and _full_above(xi[j], ub, required[j]):
                    continue
            g, pos = _kept_gain(j, nb, gain_val, gain_pos, gain_nb, gain_ok, at_row, tt, tasks,
                                pre_ptr, pre_idx, speed, path, times, n_path, late, work,
                                pos_of)
            if not g > 0.0:
                continue
            if g > cap:
                g = cap
            if single[j]:
                if not _outbids(i, g, xi[j]):
                    continue
                bid = g
                for q in range(n):
                    drop[q] = False
            else:
                valid, bid = _group_bid(i, j, xi, g, cap, team, banned, yielded, yset,
                                        required, team_reward, task_eq, agent_eq, vals,
                                        order, chosen, drop)
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
        if _insert(i, j, best, best_pos, now, xi, ti, bundle, blen, path, times, plen,
                   assigned_at, gain_ok, best_drop, single, latest, groups, at_row, tt, tasks,
                   pre_ptr, pre_idx, speed, avail, new_path, new_times, new_ready):
            held[j] = True
        else:
            blocked[j] = True
