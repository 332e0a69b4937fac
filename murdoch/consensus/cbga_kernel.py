"""A whole synchronous CBGA run as one compiled function over arrays (numba).

This is the agent-based run of `sync_runner.SyncRunner` with `cbga.CbgaAgent` restated over
arrays, step for step and with the same floating-point operations in the same order: task
quitting, bundle building (group bids with `select_group`, equipment, team reward, bans,
yields, partners' not-before times), message and byte counting, the merge of the winning-bid
matrix (CBBA's table on single-agent rows, Algorithm 2 on group rows), release of outbid
tasks, re-planning against partners' times (crossed orders, late groups) and convergence
detection. `cbga_fast.py` decides when it applies and turns its output into an
`AllocationResult`; the agent-based code stays the reference (`test_consensus_cbga_fastpath.py`).

Differences in how, not what: candidates are tried in the order of the direct-travel bound
`Problem.gain_bound` (plus the team bonus, capped) and skipped once it cannot beat the best
bid found, as the agents do, but without the tighter bounds the agents inherit from ancestor
paths; an agent's gains are kept until its path or its start times change (and per
not-before time), but paths met earlier are not remembered.

Layout: `tasks` is (7, M): window start, latest start (raw), duration, score reference time,
reward, discount, linear cost flag (the paper's cost); task j's prerequisites are
pre_idx[pre_ptr[j]:pre_ptr[j+1]]; equipment is
a bit mask per agent and per task. Agent i's beliefs are x[i] (M, N: bids, 0 = not a member)
and t[i] (M, N: when each member can be at a group task on its own, 0 = unknown), its
timestamps s[i] (N + 1, the last one -inf), its bundle (insertion order) and path (execution
order) with start times. Compiled on first use and cached on disk next to this module.

The path preparation and the insertion gain (`_prepare`, `_gain`) are the ones of
`cbba_kernel.py` with a not-before time added, restated here rather than imported: numba's
on-disk cache of a function is invalidated by changes to its own file only, so a compiled
function calling into another module could keep running a stale copy of it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.kernel_parts import DUR, EPS, NONE, WE, WS, conflict_action, gain, prepare

PARTS_SHA256 = "8a5d1efb25b5e0cf5499e367a9802172fb29968ab1cf187436e905eeb2320c44"
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
    ok = True
    bad = -1
    r = avail
    prev = -1
    finish = np.full(tasks.shape[1], np.nan)
    for n in range(n_path):
        j = path[n]
        if prev < 0:
            start = r + at_row[j] / speed
        else:
            start = r + tt[prev, j] / speed
        if tasks[WS, j] > start:
            start = tasks[WS, j]
        for e in range(pre_ptr[j], pre_ptr[j + 1]):
            f = finish[pre_idx[e]]
            if math.isnan(f):
                ok = False
            elif f > start:
                start = f
        ready[n] = start
        if groups and not single[j]:
            lb = _partners_time(i, j, xi, ti, latest)
            if lb > 0.0 and lb > start:
                start = lb
        if start > tasks[WE, j] + EPS:
            ok = False
        if not ok and bad < 0:
            bad = n
        out[n] = start
        r = start + tasks[DUR, j]
        finish[j] = r
        prev = j
    return ok, bad


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
def _sent_changed(k: int, x: np.ndarray, t: np.ndarray, x_prev: np.ndarray,
                  t_prev: np.ndarray, single: np.ndarray) -> bool:
    """Whether agent k's message (its non-zero bids, and its members' times on group rows)
    differs from the one it sent last round (`x_prev`, `t_prev`: zeros before round 1)."""
    m, n = x.shape[1], x.shape[2]
    for j in range(m):
        for q in range(n):
            v = x[k, j, q]
            if v != x_prev[k, j, q]:
                return True
            if v != 0.0 and not single[j]:
                a = t[k, j, q]
                b = t_prev[k, j, q]
                if (a > 0.0) != (b > 0.0) or (a > 0.0 and a != b):
                    return True
    return False


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
        if n_cand < 0:
            # `CbgaAgent._build_candidates` (may lift bans)
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
        n_path = plen[i]
        late = prepare(at_row, tt, tasks, speed, avail, path, times, n_path, work, pos_of)
        cap = xi[bundle[blen[i] - 1], i] if blen[i] > 0 else math.inf
        # the order: yielded group tasks first (always evaluated), then by bound
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
                if task_eq[j] == 0 and not single[j]:
                    above = ub + 1e-9 * (1.0 + ub)
                    top = 0.0
                    cnt = 0
                    for q in range(n):
                        v = xi[j, q]
                        if v > top:
                            top = v
                        if v > above:
                            cnt += 1
                    if top > above and cnt >= required[j]:
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
                yj = 0.0
                zj = NONE
                for q in range(n):
                    if xi[j, q] > yj:
                        yj = xi[j, q]
                        zj = q
                if not (g > yj or (g == yj and zj >= i)):
                    continue
                bid = g
                for q in range(n):
                    drop[q] = False
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
        for q in range(best_pos):
            new_path[q] = path[q]
        new_path[best_pos] = j
        for q in range(best_pos, n_path):
            new_path[q + 1] = path[q]
        ok, _bad = _path_starts(i, xi, ti, single, latest, groups, at_row, tt, tasks, pre_ptr,
                                pre_idx, speed, avail, new_path, n_path + 1, new_times,
                                new_ready)
        if not ok:
            blocked[j] = True
            continue
        for q in range(n_path + 1):
            path[q] = new_path[q]
            times[q] = new_times[q]
        plen[i] = n_path + 1
        for q in range(m):
            gain_ok[q] = False
        bundle[blen[i]] = j
        blen[i] += 1
        held[j] = True
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


@njit(cache=True)
def _merge(i: int, k: int, now: float, xi: np.ndarray, ti: np.ndarray, s: np.ndarray,
           xk: np.ndarray, tk: np.ndarray, s_k: np.ndarray, single: np.ndarray,
           required: np.ndarray, task_eq: np.ndarray, agent_eq: np.ndarray,
           table: np.ndarray, lut: np.ndarray, known: np.ndarray, row: np.ndarray,
           starts: np.ndarray, order: np.ndarray, chosen: np.ndarray) -> bool:
    """`CbgaAgent.receive_rows`: receiver i merges sender k's X, T and timestamps (rows are
    i's and k's; s_k[k] is the send time). True if X or T changed."""
    m, n = xi.shape
    changed = False
    n_known = 0
    for q in range(n):
        known[q] = q != i and (q == k or s_k[q] > s[q])
        if known[q]:
            n_known += 1
    for j in range(m):
        differ = False
        for q in range(n):
            if xi[j, q] != xk[j, q] or ti[j, q] != tk[j, q]:
                differ = True
                break
        if not differ:
            continue
        if single[j]:
            # CBBA's table on (y, z) read from the rows (one non-zero entry at most)
            yi = 0.0
            zi = NONE
            yk = 0.0
            zk = NONE
            for q in range(n):
                if xi[j, q] > yi:
                    yi = xi[j, q]
                    zi = q
                if xk[j, q] > yk:
                    yk = xk[j, q]
                    zk = q
            if zk == zi and yk == yi:
                continue
            action = conflict_action(i, k, yi, zi, yk, zk, s, s_k, table, lut)
            if action == 1:
                for q in range(n):
                    xi[j, q] = 0.0
                if zk != NONE:
                    xi[j, zk] = yk
                changed = True
            elif action == 2 and (yi != 0.0 or zi != NONE):
                for q in range(n):
                    xi[j, q] = 0.0
                changed = True
            continue
        if n_known == 0:
            continue
        same = True
        for q in range(n):
            if known[q] and (xi[j, q] != xk[j, q] or ti[j, q] != tk[j, q]):
                same = False
                break
        if same:
            continue
        # Algorithm 2 (`CbgaAgent._merge_group_row`)
        row_changed = False
        for q in range(n):
            row[q] = xk[j, q] if known[q] else xi[j, q]
            if row[q] != xi[j, q]:
                row_changed = True
        if row_changed:
            size = required[j]
            if task_eq[j] != 0:
                _select_group(row, size, task_eq[j], agent_eq, order, chosen)
                for q in range(n):
                    if not chosen[q]:
                        row[q] = 0.0
            else:
                cnt = _rank(row, order)
                if size < cnt:
                    for p in range(size, cnt):
                        row[order[p]] = 0.0
        for q in range(n):
            starts[q] = ti[j, q] if row[q] > 0.0 else 0.0
        starts[i] = ti[j, i]
        for q in range(n):
            if known[q]:
                v = row[q]
                if v > 0.0 and xk[j, q] == v:
                    starts[q] = tk[j, q]
        diff = False
        for q in range(n):
            if row[q] != xi[j, q] or starts[q] != ti[j, q]:
                diff = True
                break
        if diff:
            for q in range(n):
                xi[j, q] = row[q]
                ti[j, q] = starts[q]
            changed = True
    # `cbba.merge_timestamps`
    for q in range(n):
        if s_k[q] > s[q]:
            s[q] = s_k[q]
    s[k] = now
    if now > s[i]:
        s[i] = now
    s[n] = -math.inf
    return changed


@njit(cache=True)
def _retime(i: int, xi: np.ndarray, ti: np.ndarray, path: np.ndarray, times: np.ndarray,
            plen: np.ndarray, gain_ok: np.ndarray, at_row: np.ndarray, tt: np.ndarray,
            tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float,
            avail: float, single: np.ndarray, latest: np.ndarray, groups: bool,
            ready: np.ndarray) -> None:
    """`_set_path(path, path_starts(...)[0])` then `_publish_times()` on the current path."""
    _path_starts(i, xi, ti, single, latest, groups, at_row, tt, tasks, pre_ptr, pre_idx,
                 speed, avail, path, plen[i], times, ready)
    for q in range(gain_ok.shape[0]):
        gain_ok[q] = False
    if groups:
        _publish(i, ti, single, path, plen[i], ready)


@njit(cache=True)
def _remove(path: np.ndarray, plen: np.ndarray, i: int, drop: np.ndarray) -> None:
    kept = 0
    for q in range(plen[i]):
        if not drop[path[q]]:
            path[kept] = path[q]
            kept += 1
    plen[i] = kept


@njit(cache=True)
def _quit(i: int, now: float, xi: np.ndarray, ti: np.ndarray, bundle: np.ndarray,
          blen: np.ndarray, path: np.ndarray, times: np.ndarray, plen: np.ndarray,
          assigned_at: np.ndarray, banned: np.ndarray, quits: np.ndarray,
          gain_ok: np.ndarray, at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray,
          pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float, avail: float,
          single: np.ndarray, latest: np.ndarray, groups: bool, quit_after: np.ndarray,
          required: np.ndarray, task_eq: np.ndarray, agent_eq: np.ndarray, quit_limit: int,
          ready: np.ndarray) -> bool:
    """`CbgaAgent.quit_stalled`: leave the first group task still incomplete after its
    threshold (the caller checks that quitting is on)."""
    m, n = xi.shape
    for b in range(blen[i]):
        j = bundle[b]
        if single[j] or not math.isfinite(quit_after[j]):
            continue
        if now - assigned_at[j] >= quit_after[j] and not _complete(j, xi, required, task_eq,
                                                                  agent_eq):
            others = -1
            for q in range(n):
                if xi[j, q] > 0.0:
                    others += 1
            xi[j, i] = 0.0
            for r in range(b, blen[i] - 1):
                bundle[r] = bundle[r + 1]
            blen[i] -= 1
            drop = np.zeros(m, dtype=np.bool_)
            drop[j] = True
            _remove(path, plen, i, drop)
            _retime(i, xi, ti, path, times, plen, gain_ok, at_row, tt, tasks, pre_ptr,
                    pre_idx, speed, avail, single, latest, groups, ready)
            quits[j] += 1
            if quits[j] < quit_limit:
                banned[j] = others if others > 0 else 0
            else:
                banned[j] = n
            return True
    return False


@njit(cache=True)
def _release(i: int, xi: np.ndarray, ti: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
             path: np.ndarray, times: np.ndarray, plen: np.ndarray, gain_ok: np.ndarray,
             at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
             pre_idx: np.ndarray, speed: float, avail: float, single: np.ndarray,
             latest: np.ndarray, groups: bool, ready: np.ndarray) -> bool:
    """`CbgaAgent.release_outbid`: drop the first bundle task agent i no longer holds and
    every task after it (those are reset); True if anything was dropped."""
    m = xi.shape[0]
    for b in range(blen[i]):
        if xi[bundle[b], i] > 0.0:
            continue
        drop = np.zeros(m, dtype=np.bool_)
        for r in range(b, blen[i]):
            j = bundle[r]
            drop[j] = True
            if r > b:
                if single[j]:
                    for q in range(xi.shape[1]):
                        xi[j, q] = 0.0
                else:
                    xi[j, i] = 0.0
        blen[i] = b
        _remove(path, plen, i, drop)
        _retime(i, xi, ti, path, times, plen, gain_ok, at_row, tt, tasks, pre_ptr, pre_idx,
                speed, avail, single, latest, groups, ready)
        return True
    return False


@njit(cache=True)
def _refresh(i: int, xi: np.ndarray, ti: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
             path: np.ndarray, times: np.ndarray, plen: np.ndarray, yielding: np.ndarray,
             yielded: np.ndarray, yset: np.ndarray, gain_ok: np.ndarray, at_row: np.ndarray,
             tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray,
             speed: float, avail: float, single: np.ndarray, latest: np.ndarray, groups: bool,
             new_times: np.ndarray, ready: np.ndarray) -> bool:
    """`CbgaAgent.refresh_times` (the caller checks that there are group tasks)."""
    m, n = xi.shape
    # `_drop_crossed_orders`: of two group tasks planned in the opposite order to a
    # higher-index partner, drop the later one
    dropped = False
    later = np.zeros(m, dtype=np.bool_)
    n_shared = 0
    for q in range(plen[i]):
        if not single[path[q]]:
            n_shared += 1
    if n_shared >= 2:
        for a in range(plen[i]):
            g = path[a]
            if single[g] or later[g]:
                continue
            for c in range(a + 1, plen[i]):
                h = path[c]
                if single[h] or later[h]:
                    continue
                found = False
                for q in range(i + 1, n):
                    if (xi[g, q] > 0.0 and xi[h, q] > 0.0 and ti[g, q] > 0.0
                            and ti[h, q] > 0.0 and ti[h, q] < ti[g, q]):
                        if not found:
                            found = True
                            for r in range(n):
                                yset[h, r] = False
                        yset[h, q] = True
                if found:
                    later[h] = True
                    yielded[h] = True
                    dropped = True
    if dropped:
        for j in range(m):
            if later[j]:
                xi[j, i] = 0.0
        kept = 0
        for b in range(blen[i]):
            if not later[bundle[b]]:
                bundle[kept] = bundle[b]
                kept += 1
        blen[i] = kept
        _remove(path, plen, i, later)
    held = False
    while True:
        ok, bad = _path_starts(i, xi, ti, single, latest, groups, at_row, tt, tasks, pre_ptr,
                               pre_idx, speed, avail, path, plen[i], new_times, ready)
        if ok:
            break
        j = path[bad]
        # `_blamed_partner`: the partner waited for last, on a group task before path[bad]
        blamed = -1
        for p in range(bad - 1, -1, -1):
            g = path[p]
            if not single[g] and _partners_time(i, g, xi, ti, latest) > ready[p]:
                best = -math.inf
                who = 0
                for q in range(n):
                    if xi[g, q] > 0.0 and q != i and ti[g, q] > best:
                        best = ti[g, q]
                        who = q
                blamed = who
                break
        if blamed >= 0 and blamed < i and yielding[i] != j:
            yielding[i] = j
            held = True
            break
        xi[j, i] = 0.0
        for b in range(blen[i]):
            if bundle[b] == j:
                for r in range(b, blen[i] - 1):
                    bundle[r] = bundle[r + 1]
                blen[i] -= 1
                break
        for q in range(bad, plen[i] - 1):
            path[q] = path[q + 1]
        plen[i] -= 1
        dropped = True
    if not held:
        yielding[i] = -1
    moved = dropped
    if not moved:
        for q in range(plen[i]):
            if new_times[q] != times[q]:
                moved = True
                break
    if moved:
        for q in range(plen[i]):
            times[q] = new_times[q]
        for q in range(m):
            gain_ok[q] = False
    _publish(i, ti, single, path, plen[i], ready)
    return moved


@njit(cache=True)
def _pending_quit(xi: np.ndarray, bundle: np.ndarray, nb: int, assigned_at: np.ndarray,
                  quit_after: np.ndarray, single: np.ndarray, required: np.ndarray,
                  task_eq: np.ndarray, agent_eq: np.ndarray) -> bool:
    """`CbgaAgent.next_quit_time() < inf` (the caller checks that quitting is on)."""
    for b in range(nb):
        j = bundle[b]
        if (not single[j] and math.isfinite(quit_after[j])
                and not _complete(j, xi, required, task_eq, agent_eq)
                and assigned_at[j] + quit_after[j] < math.inf):
            return True
    return False


@njit(cache=True)
def run_cbga(at_dist: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
             pre_idx: np.ndarray, speed: np.ndarray, avail: np.ndarray, eligible: np.ndarray,
             gain_bound: np.ndarray, max_depth: int, required: np.ndarray,
             team_reward: np.ndarray, quit_after: np.ndarray, task_eq: np.ndarray,
             agent_eq: np.ndarray, quitting: bool, team: bool, quit_limit: int,
             nbr_ptr: np.ndarray, nbr_idx: np.ndarray, out_degree: np.ndarray, diameter: int,
             max_rounds: int, table: np.ndarray, lut: np.ndarray, msg_base: int,
             msg_entry: int, team_total: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int, int, int, bool, int]:
    """Synchronous CBGA to convergence. Returns (paths (N, M + 1), path lengths, every
    agent's X (N, M, N), rounds, comm_steps, messages, bytes, converged, pairwise steps: the
    sends among those messages whose entries or members' times differ from the sender's
    previous round's)."""
    n, m = at_dist.shape
    single = required == 1
    n_groups = 0
    for j in range(m):
        if not single[j]:
            n_groups += 1
    groups = n_groups > 0  # (a computed flag: a literal one would compile callees twice)
    latest = tasks[WE] + EPS
    x = np.zeros((n, m, n))
    t = np.zeros((n, m, n))
    s = np.full((n, n + 1), -math.inf)
    bundle = np.zeros((n, m), dtype=np.int64)
    blen = np.zeros(n, dtype=np.int64)
    path = np.zeros((n, m + 1), dtype=np.int64)
    times = np.zeros((n, m + 1))
    plen = np.zeros(n, dtype=np.int64)
    needs = np.ones(n, dtype=np.bool_)
    assigned_at = np.full((n, m), np.nan)
    banned = np.full((n, m), -1, dtype=np.int64)
    quits = np.zeros((n, m), dtype=np.int64)
    yielding = np.full(n, -1, dtype=np.int64)
    yielded = np.zeros((n, m), dtype=np.bool_)
    yset = np.zeros((n, m, n), dtype=np.bool_)
    gain_val = np.zeros((n, m))
    gain_pos = np.zeros((n, m), dtype=np.int64)
    gain_nb = np.zeros((n, m))
    gain_ok = np.zeros((n, m), dtype=np.bool_)
    work = np.zeros((5, m + 2))
    ready = np.zeros(m + 1)
    new_times = np.zeros(m + 1)
    known = np.zeros(n, dtype=np.bool_)
    row = np.zeros(n)
    starts = np.zeros(n)
    order = np.zeros(n, dtype=np.int64)
    chosen = np.zeros(n, dtype=np.bool_)
    x_sent = x.copy()
    t_sent = t.copy()
    s_sent = s.copy()
    x_before = x.copy()
    t_before = t.copy()
    b_before = bundle.copy()
    blen_before = blen.copy()
    sent_msgs = 0
    sent_bytes = 0
    sent_pairs = 0
    pairwise = 0
    messages = 0
    nbytes = 0
    rnd = 0
    last_change = 0
    quiet = 0
    while True:
        pending = False
        if quitting:
            for i in range(n):
                if _pending_quit(x[i], bundle[i], blen[i], assigned_at[i], quit_after,
                                 single, required, task_eq, agent_eq):
                    pending = True
                    break
        if (quiet >= diameter + 1 and not pending) or rnd >= max_rounds:
            break
        rnd += 1
        now = float(rnd)
        _copy(x_before, x)
        _copy(t_before, t)
        for i in range(n):
            blen_before[i] = blen[i]
            for b in range(blen[i]):
                b_before[i, b] = bundle[i, b]
        # -- task quitting
        if quitting:
            for i in range(n):
                if _quit(i, now, x[i], t[i], bundle[i], blen, path[i], times[i], plen,
                         assigned_at[i], banned[i], quits[i], gain_ok[i], at_dist[i], tt,
                         tasks, pre_ptr, pre_idx, speed[i], avail[i], single, latest, groups,
                         quit_after, required, task_eq, agent_eq, quit_limit, ready):
                    needs[i] = True
        # -- phase 1: bundle building, agent by agent
        for i in range(n):
            if needs[i]:
                needs[i] = False
                _build(i, now, x[i], t[i], bundle[i], blen, path[i], times[i], plen,
                       assigned_at[i], banned[i], quits[i], yielded[i], yset[i],
                       gain_val[i], gain_pos[i], gain_nb[i], gain_ok[i], at_dist[i], tt,
                       tasks, pre_ptr, pre_idx, speed[i], avail[i], eligible[i],
                       gain_bound[i], single, latest, groups, required, team_reward,
                       task_eq, agent_eq, team, quit_limit, max_depth, work, team_total)
        # -- what the round's messages cost (`CbgaAgent.sent_counts`)
        for k in range(n):
            d = out_degree[k]
            if d == 0:
                continue
            entries = 0
            n_starts = 0
            for j in range(m):
                for q in range(n):
                    if x[k, j, q] != 0.0:
                        entries += 1
                        if not single[j] and t[k, j, q] > 0.0 and x[k, j, q] > 0.0:
                            n_starts += 1
            sent_msgs += d
            sent_bytes += d * (msg_base + (entries + n_starts) * msg_entry)
            if _sent_changed(k, x, t, x_sent, t_sent, single):
                sent_pairs += d
        # -- phase 2: everyone sends, then each merges its neighbours' messages in order
        _copy(x_sent, x)
        _copy(t_sent, t)
        for i in range(n):
            for q in range(n + 1):
                s_sent[i, q] = s[i, q]
            s_sent[i, i] = now
        for i in range(n):
            for e in range(nbr_ptr[i], nbr_ptr[i + 1]):
                k = nbr_idx[e]
                if _merge(i, k, now, x[i], t[i], s[i], x_sent[k], t_sent[k], s_sent[k],
                          single, required, task_eq, agent_eq, table, lut, known, row,
                          starts, order, chosen):
                    needs[i] = True
        # -- release what each agent was outbid on, then re-plan against its partners
        for i in range(n):
            if _release(i, x[i], t[i], bundle[i], blen, path[i], times[i], plen, gain_ok[i],
                        at_dist[i], tt, tasks, pre_ptr, pre_idx, speed[i], avail[i], single,
                        latest, groups, ready):
                needs[i] = True
            if groups and _refresh(i, x[i], t[i], bundle[i], blen, path[i], times[i], plen,
                                   yielding, yielded[i], yset[i], gain_ok[i], at_dist[i], tt,
                                   tasks, pre_ptr, pre_idx, speed[i], avail[i], single,
                                   latest, groups, new_times, ready):
                needs[i] = True
        # -- did anything that comm_steps watches (X, T, bundles) change over the round?
        changed = False
        for i in range(n):
            if blen[i] != blen_before[i]:
                changed = True
                break
            for b in range(blen[i]):
                if bundle[i, b] != b_before[i, b]:
                    changed = True
            if changed:
                break
        if not changed:
            for i in range(n):
                for j in range(m):
                    for q in range(n):
                        if x[i, j, q] != x_before[i, j, q] or t[i, j, q] != t_before[i, j, q]:
                            changed = True
                            break
                    if changed:
                        break
                if changed:
                    break
        if changed:
            last_change = rnd
            messages = sent_msgs
            nbytes = sent_bytes
            pairwise = sent_pairs
            quiet = 0
        else:
            quiet += 1
    pending = False
    if quitting:
        for i in range(n):
            if _pending_quit(x[i], bundle[i], blen[i], assigned_at[i], quit_after, single,
                             required, task_eq, agent_eq):
                pending = True
    converged = quiet >= diameter + 1 and not pending
    return path, plen, x, rnd, last_change, messages, nbytes, converged, pairwise
