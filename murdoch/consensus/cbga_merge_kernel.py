"""Phase 2 of the compiled CBGA run and what follows it: the merge of a neighbour's X, T and
timestamps (`CbgaAgent.receive_rows`), task quitting, release of outbid tasks and re-planning
against the partners' times (`refresh_times`; see `cbga_kernel`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.cbga_kernel_parts import (
    _complete,
    _copy,
    _partners_time,
    _path_starts,
    _publish,
    _rank,
    _remove,
    _retime,
    _select_group,
)
from murdoch.consensus.kernel_parts import NONE, conflict_action

SOURCES_SHA256 = {
    "kernel_parts.py": "48acf80e0cde01c59b7422d086ad54ef9789e4fcdad8d5835d7b9ab48604f2af",
    "cbga_kernel_parts.py": "9ee7999199310d41f4d0269c6e20003f088cdaf282abee0f13f2fc072f4afa38",
}
"""The kernel files this module's compiled code was built from (see `kernel_parts`)."""


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
def _any_pending_quit(x: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
                      assigned_at: np.ndarray, quit_after: np.ndarray, single: np.ndarray,
                      required: np.ndarray, task_eq: np.ndarray, agent_eq: np.ndarray) -> bool:
    """Whether some agent has a quit still to come (`_pending_quit` of any agent)."""
    for i in range(x.shape[0]):
        if _pending_quit(x[i], bundle[i], blen[i], assigned_at[i], quit_after, single,
                         required, task_eq, agent_eq):
            return True
    return False


@njit(cache=True)
def _replan(x: np.ndarray, t: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
            path: np.ndarray, times: np.ndarray, plen: np.ndarray, yielding: np.ndarray,
            yielded: np.ndarray, yset: np.ndarray, gain_ok: np.ndarray, at_dist: np.ndarray,
            tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray,
            speed: np.ndarray, avail: np.ndarray, single: np.ndarray, latest: np.ndarray,
            groups: bool, new_times: np.ndarray, ready: np.ndarray, needs: np.ndarray) -> None:
    """Every agent releases what it was outbid on, then re-plans against its partners
    (`needs` marks those that changed)."""
    for i in range(x.shape[0]):
        if _release(i, x[i], t[i], bundle[i], blen, path[i], times[i], plen, gain_ok[i],
                    at_dist[i], tt, tasks, pre_ptr, pre_idx, speed[i], avail[i], single,
                    latest, groups, ready):
            needs[i] = True
        if groups and _refresh(i, x[i], t[i], bundle[i], blen, path[i], times[i], plen,
                               yielding, yielded[i], yset[i], gain_ok[i], at_dist[i], tt,
                               tasks, pre_ptr, pre_idx, speed[i], avail[i], single, latest,
                               groups, new_times, ready):
            needs[i] = True


@njit(cache=True)
def _exchange(now: float, x: np.ndarray, t: np.ndarray, s: np.ndarray, x_sent: np.ndarray,
              t_sent: np.ndarray, s_sent: np.ndarray, nbr_ptr: np.ndarray, nbr_idx: np.ndarray,
              single: np.ndarray, required: np.ndarray, task_eq: np.ndarray,
              agent_eq: np.ndarray, table: np.ndarray, lut: np.ndarray, known: np.ndarray,
              row: np.ndarray, starts: np.ndarray, order: np.ndarray, chosen: np.ndarray,
              needs: np.ndarray) -> None:
    """Phase 2: every agent sends (X, T, its timestamps stamped now), then each merges its
    neighbours' messages in neighbour order; `needs` marks those whose X or T changed."""
    n = x.shape[0]
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
