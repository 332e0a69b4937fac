"""A whole synchronous CBBA run as one compiled function over arrays (numba).

This is the agent-based run of `sync_runner.SyncRunner` with `cbba.CbbaAgent` (bundle building
with time-window insertion, the 17-rule conflict table, timestamps, release of outbid tasks,
message and byte counting, convergence detection) restated over (agents x tasks) arrays, step
for step and with the same floating-point operations in the same order, so that it gives the
same bids, paths, rounds and counts. `cbba_fast.py` decides when it applies and turns its
output into an `AllocationResult`; the agent-based code stays the reference (see
`test_consensus_fastpath.py`).

Differences in how, not what: candidates are tried in the order of the direct-travel bound
`Problem.gain_bound` and skipped once it cannot beat the best bid found, as the agents do, but
without the tighter bounds the agents inherit from ancestor paths (so the kernel evaluates a
few more tasks, and picks the same one); each agent's gains are kept until its path changes,
but paths met earlier are not remembered.

Layout: `tasks` is (7, M): window start, latest start (raw, no tolerance), duration, score
reference time, reward, discount, linear cost flag (the paper's cost); task j's
prerequisites are pre_idx[pre_ptr[j]:pre_ptr[j+1]];
the state is one row per agent (y, z, bundle in insertion order, path in execution order and
its start times). Each phase is its own small function (which also compiles faster).
Compiled on first use and cached on disk next to this module (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.kernel_parts import (
    NONE,
    bundles_changed,
    close_round,
    commit_path,
    count_sends,
    cut_bundle,
    forget_gains,
    gain,
    held_tasks,
    insert_task,
    merge_stamps,
    new_tally,
    path_starts,
    prepare,
    remember_bundles,
    reported,
    settle_task,
    settled,
)

PARTS_SHA256 = "faf09f64dff8c2f95bf3bd53767118afd737e73822b364b9c8ad27114769815b"
"""The `kernel_parts.py` this module was written against (see its notes on numba's cache)."""


@njit(cache=True)
def _path_starts(at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
                 pre_idx: np.ndarray, speed: float, avail: float, path: np.ndarray,
                 n_path: int, out: np.ndarray) -> bool:
    """`scoring.path_starts` without group bounds: start times along the path (into `out`)
    and whether each fits its window after its prerequisites, earlier on the path."""
    ok, _bad = path_starts(at_row, tt, tasks, pre_ptr, pre_idx, speed, avail, path, n_path,
                           np.zeros(tasks.shape[1]), out, np.zeros(n_path + 1))
    return ok


@njit(cache=True)
def _build(i: int, y: np.ndarray, z: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
           path: np.ndarray, times: np.ndarray, plen: np.ndarray, at_row: np.ndarray,
           tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray,
           speed: float, avail: float,
           eligible: np.ndarray, bound: np.ndarray, max_depth: int, gain_val: np.ndarray,
           gain_pos: np.ndarray, gain_ok: np.ndarray, work: np.ndarray) -> None:
    """Agent i's bundle building (`BundleBuilding.build_bundle` with `CbbaAgent._add_best`);
    y, z, bundle, path, times, gain_* are agent i's rows."""
    m = y.shape[0]
    blocked = np.zeros(m, dtype=np.bool_)
    held = held_tasks(i, bundle, blen, m)
    cand_ub = np.zeros(m)
    cand_j = np.zeros(m, dtype=np.int64)
    new_path = np.zeros(m + 1, dtype=np.int64)
    new_times = np.zeros(m + 1)
    pos_of = np.zeros(m, dtype=np.int64)
    while blen[i] < max_depth:
        n_path = plen[i]
        late = prepare(at_row, tt, tasks, speed, avail, path, times, n_path, work, pos_of)
        cap = y[bundle[blen[i] - 1]] if blen[i] > 0 else math.inf
        # candidates by upper bound, highest first (ties: lower index first), as
        # `CbbaAgent._add_best` filters and orders them
        n_cand = 0
        for j in range(m):
            yj = y[j]
            ub = bound[j]
            if not eligible[j] or blocked[j] or ub < yj or held[j]:
                continue
            if cap < ub:
                ub = cap
            if ub > 0.0 and ub >= yj:
                q = n_cand  # insertion sort: after every higher or equal bound
                while q > 0 and cand_ub[q - 1] < ub:
                    cand_ub[q] = cand_ub[q - 1]
                    cand_j[q] = cand_j[q - 1]
                    q -= 1
                cand_ub[q] = ub
                cand_j[q] = j
                n_cand += 1
        best = -math.inf
        best_j = -1
        best_pos = 0
        for o in range(n_cand):
            ub = cand_ub[o]
            j = cand_j[o]
            if ub < best:
                break
            if ub == best and j > best_j:
                continue
            if gain_ok[j]:
                g = gain_val[j]
                pos = gain_pos[j]
            else:
                g, pos = gain(j, 0.0, at_row, tt, tasks, pre_ptr, pre_idx, speed, path, times,
                               n_path, late, work, pos_of)
                gain_val[j] = g
                gain_pos[j] = pos
                gain_ok[j] = True
            if g > cap:
                g = cap
            yj = y[j]
            if g > 0.0 and (g > yj or (g == yj and z[j] >= i)) and (
                    g > best or (g == best and j < best_j)):
                best = g
                best_j = j
                best_pos = pos
        if best_j < 0:
            return
        # insert best_j at best_pos and re-time the path
        insert_task(path, n_path, best_pos, best_j, new_path)
        if not _path_starts(at_row, tt, tasks, pre_ptr, pre_idx, speed, avail, new_path,
                            n_path + 1, new_times):
            blocked[best_j] = True
            continue
        commit_path(i, best_j, n_path, new_path, new_times, path, times, plen, gain_ok, bundle,
                    blen, held)
        y[best_j] = best
        z[best_j] = i


@njit(cache=True)
def _merge(i: int, k: int, now: float, y: np.ndarray, z: np.ndarray, s: np.ndarray,
           y_k: np.ndarray, z_k: np.ndarray, s_k: np.ndarray, table: np.ndarray,
           lut: np.ndarray) -> bool:
    """Receiver i applies sender k's message (`conflict.resolve_lists`, then
    `cbba.merge_timestamps`); rows are i's and k's. True if y or z changed."""
    changed = False
    for j in range(y.shape[0]):
        yj, zj, moved = settle_task(i, k, y[j], z[j], y_k[j], z_k[j], s, s_k, table, lut)
        if moved:
            y[j] = yj
            z[j] = zj
            changed = True
    merge_stamps(s, s_k, k, i, now)
    return changed


@njit(cache=True)
def _release(i: int, y: np.ndarray, z: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
             path: np.ndarray, times: np.ndarray, plen: np.ndarray, at_row: np.ndarray,
             tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray,
             speed: float, avail: float, gain_ok: np.ndarray) -> bool:
    """`CbbaAgent.release_outbid`: drop the first bundle task agent i no longer wins and
    every task after it (those are reset); True if anything was dropped."""
    for b in range(blen[i]):
        if z[bundle[b]] == i:
            continue
        for r in range(b + 1, blen[i]):
            y[bundle[r]] = 0.0
            z[bundle[r]] = NONE
        cut_bundle(i, b, bundle, blen, path, plen, y.shape[0])
        forget_gains(gain_ok)
        _path_starts(at_row, tt, tasks, pre_ptr, pre_idx, speed, avail, path, plen[i], times)
        return True
    return False


@njit(cache=True)
def _round_cost(y: np.ndarray, z: np.ndarray, y_sent: np.ndarray, z_sent: np.ndarray,
                out_degree: np.ndarray, msg_base: int, msg_entry: int,
                tally: np.ndarray) -> None:
    """One round's sends, counted into the tally (`count_sends`): a message carries the
    sender's assigned entries, and is a pairwise step when its (y, z) entries differ from
    what the sender sent the round before, held in y_sent, z_sent."""
    n, m = z.shape
    entries = np.zeros(n, dtype=np.int64)
    changed = np.zeros(n, dtype=np.bool_)
    for k in range(n):
        if out_degree[k] == 0:
            continue
        for j in range(m):
            if z[k, j] != NONE:
                entries[k] += 1
        for j in range(m):
            if z[k, j] != z_sent[k, j] or (z[k, j] != NONE and y[k, j] != y_sent[k, j]):
                changed[k] = True
                break
    count_sends(out_degree, entries, changed, msg_base, msg_entry, tally)


@njit(cache=True)
def _round_changed(y: np.ndarray, z: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
                   y_before: np.ndarray, z_before: np.ndarray, b_before: np.ndarray,
                   blen_before: np.ndarray) -> bool:
    """Whether the bids, winners or bundles differ from those at the start of the round."""
    if bundles_changed(bundle, blen, b_before, blen_before):
        return True
    n, m = z.shape
    for i in range(n):
        for j in range(m):
            if y[i, j] != y_before[i, j] or z[i, j] != z_before[i, j]:
                return True
    return False


@njit(cache=True)
def run_cbba(at_dist: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
             pre_idx: np.ndarray, speed: np.ndarray, avail: np.ndarray, eligible: np.ndarray,
             gain_bound: np.ndarray, max_depth: int, nbr_ptr: np.ndarray, nbr_idx: np.ndarray,
             out_degree: np.ndarray, diameter: int, max_rounds: int, table: np.ndarray,
             lut: np.ndarray, msg_base: int, msg_entry: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int,
                        int, int, bool, int]:
    """Synchronous CBBA to convergence. Returns (paths (N, M + 1), path lengths, winners z
    (N, M), bids y (N, M), start times (N, M + 1), rounds, comm_steps, messages, bytes,
    converged, pairwise steps: the sends among those messages whose (y, z) entries differ
    from the sender's previous round's)."""
    n, m = at_dist.shape
    y = np.zeros((n, m))
    z = np.full((n, m), NONE, dtype=np.int64)
    s = np.full((n, n + 1), -math.inf)
    bundle = np.zeros((n, m), dtype=np.int64)
    blen = np.zeros(n, dtype=np.int64)
    path = np.zeros((n, m + 1), dtype=np.int64)
    times = np.zeros((n, m + 1))
    plen = np.zeros(n, dtype=np.int64)
    needs = np.ones(n, dtype=np.bool_)
    # gains of each agent's current path, evaluated on demand (valid until it changes)
    gain_val = np.zeros((n, m))
    gain_pos = np.zeros((n, m), dtype=np.int64)
    gain_ok = np.zeros((n, m), dtype=np.bool_)
    work = np.zeros((5, m + 2))
    y_sent = y.copy()
    z_sent = z.copy()
    s_sent = s.copy()
    y_before = y.copy()
    z_before = z.copy()
    b_before = bundle.copy()
    blen_before = blen.copy()
    tally = new_tally()
    rnd = 0
    while not settled(tally, diameter) and rnd < max_rounds:
        rnd += 1
        now = float(rnd)
        remember_bundles(bundle, blen, b_before, blen_before)
        for i in range(n):
            for j in range(m):
                y_before[i, j] = y[i, j]
                z_before[i, j] = z[i, j]
        # -- phase 1: bundle building, agent by agent
        for i in range(n):
            if needs[i]:
                needs[i] = False
                _build(i, y[i], z[i], bundle[i], blen, path[i], times[i], plen, at_dist[i],
                       tt, tasks, pre_ptr, pre_idx, speed[i], avail[i], eligible[i],
                       gain_bound[i],
                       max_depth, gain_val[i], gain_pos[i], gain_ok[i], work)
        # -- what the round's messages cost (y_sent, z_sent: what was sent last round)
        _round_cost(y, z, y_sent, z_sent, out_degree, msg_base, msg_entry, tally)
        # -- phase 2: everyone sends, then each merges its neighbours' messages in order
        for i in range(n):
            for j in range(m):
                y_sent[i, j] = y[i, j]
                z_sent[i, j] = z[i, j]
            for q in range(n + 1):
                s_sent[i, q] = s[i, q]
            s_sent[i, i] = now
        for i in range(n):
            for e in range(nbr_ptr[i], nbr_ptr[i + 1]):
                k = nbr_idx[e]
                if _merge(i, k, now, y[i], z[i], s[i], y_sent[k], z_sent[k], s_sent[k],
                          table, lut):
                    needs[i] = True
        # -- release the first outbid bundle task and every task added after it
        for i in range(n):
            if _release(i, y[i], z[i], bundle[i], blen, path[i], times[i], plen,
                        at_dist[i], tt, tasks, pre_ptr, pre_idx, speed[i], avail[i],
                        gain_ok[i]):
                needs[i] = True
        # -- did anything that comm_steps watches (y, z, bundles) change over the round?
        close_round(tally, rnd, _round_changed(y, z, bundle, blen, y_before, z_before, b_before,
                                               blen_before))
    converged = settled(tally, diameter)
    comm_steps, messages, nbytes, pairwise = reported(tally)
    return path, plen, z, y, times, rnd, comm_steps, messages, nbytes, converged, pairwise
