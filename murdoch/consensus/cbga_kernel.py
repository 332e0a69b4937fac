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

Phase 1 (bundle building) is in `cbga_build_kernel.py`, the round's bookkeeping (state
arrays, message costs, change detection) in `cbga_round_kernel.py`; the parts shared with
CBBA's run (path preparation, insertion gain, conflict rules) are in `kernel_parts.py`.
numba's on-disk cache of a function is invalidated by changes to its own file only, so this
module names the fingerprints of the files it compiles in (`PARTS_SHA256`, `BUILD_SHA256`,
`ROUND_SHA256`), and
`test_consensus_kernel_parts.py` keeps them current.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.cbga_build_kernel import (
    _build,
    _complete,
    _copy,
    _partners_time,
    _path_starts,
    _publish,
    _rank,
    _select_group,
)
from murdoch.consensus.cbga_round_kernel import (
    _any_pending_quit,
    _gain_cache,
    _group_state,
    _lists,
    _merge_scratch,
    _remember,
    _round_changed,
    _round_cost,
    _stamp_sent,
)
from murdoch.consensus.kernel_parts import (
    EPS,
    NONE,
    WE,
    close_round,
    cut_bundle,
    forget_gains,
    merge_stamps,
    new_tally,
    remove_marked,
    reported,
    row_winner,
    settle_task,
    settled,
)

PARTS_SHA256 = "faf09f64dff8c2f95bf3bd53767118afd737e73822b364b9c8ad27114769815b"
"""The `kernel_parts.py` this module was written against (see its notes on numba's cache)."""
BUILD_SHA256 = "306aab6ca89c2683d05e8d43d026038fa3551d4a651e06e681c0c66b16b044a2"
"""The `cbga_build_kernel.py` this module was written against."""
ROUND_SHA256 = "a2f2d1c758bc6ef8fc11cb0f1fb18047770f42a03f7d706e136546409ccc83cb"
"""The `cbga_round_kernel.py` this module was written against."""


@njit(cache=True)
def _keep_group(row: np.ndarray, size: int, need: int, agent_eq: np.ndarray,
                order: np.ndarray, chosen: np.ndarray) -> None:
    """Zero the bids in a group row outside the group it keeps: `select_group` when the task
    needs equipment, else the `size` strongest."""
    if need != 0:
        _select_group(row, size, need, agent_eq, order, chosen)
        for q in range(row.shape[0]):
            if not chosen[q]:
                row[q] = 0.0
    else:
        cnt = _rank(row, order)
        for p in range(size, cnt):
            row[order[p]] = 0.0


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
            yi, zi = row_winner(xi[j])
            yk, zk = row_winner(xk[j])
            yj, zj, moved = settle_task(i, k, yi, zi, yk, zk, s, s_k, table, lut)
            if moved:
                for q in range(n):
                    xi[j, q] = 0.0
                if zj != NONE:
                    xi[j, zj] = yj
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
            _keep_group(row, required[j], task_eq[j], agent_eq, order, chosen)
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
    merge_stamps(s, s_k, k, i, now)
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
    forget_gains(gain_ok)
    if groups:
        _publish(i, ti, single, path, plen[i], ready)


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
            remove_marked(path, plen, i, drop)
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
        for r in range(b + 1, blen[i]):
            j = bundle[r]
            if single[j]:
                for q in range(xi.shape[1]):
                    xi[j, q] = 0.0
            else:
                xi[j, i] = 0.0
        cut_bundle(i, b, bundle, blen, path, plen, m)
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
        remove_marked(bundle, blen, i, later)
        remove_marked(path, plen, i, later)
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
        forget_gains(gain_ok)
    _publish(i, ti, single, path, plen[i], ready)
    return moved


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
    x, t, s, bundle, blen, path, times, plen, needs = _lists(n, m)
    assigned_at, banned, quits, yielding, yielded, yset = _group_state(n, m)
    gain_val, gain_pos, gain_nb, gain_ok = _gain_cache(n, m)
    work = np.zeros((5, m + 2))
    ready = np.zeros(m + 1)
    new_times = np.zeros(m + 1)
    known, row, starts, order, chosen = _merge_scratch(n)
    x_sent = x.copy()
    t_sent = t.copy()
    s_sent = s.copy()
    x_before = x.copy()
    t_before = t.copy()
    b_before = bundle.copy()
    blen_before = blen.copy()
    tally = new_tally()
    rnd = 0
    while True:
        pending = quitting and _any_pending_quit(x, bundle, blen, assigned_at, quit_after,
                                                 single, required, task_eq, agent_eq)
        if (settled(tally, diameter) and not pending) or rnd >= max_rounds:
            break
        rnd += 1
        now = float(rnd)
        _remember(x, t, bundle, blen, x_before, t_before, b_before, blen_before)
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
        _round_cost(x, t, x_sent, t_sent, out_degree, single, msg_base, msg_entry, tally)
        # -- phase 2: everyone sends, then each merges its neighbours' messages in order
        _copy(x_sent, x)
        _copy(t_sent, t)
        _stamp_sent(s, s_sent, now)
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
        close_round(tally, rnd, _round_changed(x, t, bundle, blen, x_before, t_before, b_before,
                                               blen_before))
    pending = quitting and _any_pending_quit(x, bundle, blen, assigned_at, quit_after, single,
                                             required, task_eq, agent_eq)
    converged = settled(tally, diameter) and not pending
    comm_steps, messages, nbytes, pairwise = reported(tally)
    return path, plen, x, rnd, comm_steps, messages, nbytes, converged, pairwise
