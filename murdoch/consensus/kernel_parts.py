"""What the compiled CBBA and CBGA runs share: task rows, path gains and the conflict table.

`cbba_kernel` and `cbga_kernel` restate the agents' code over arrays; the parts both need
are written once here: the layout of the task rows and of the per-path work array, the
gains of inserting a task into a path (`gains.PathGains`), and CBBA's conflict rules applied
to one task (`conflict.resolve_lists`, with the table and look-up arrays of
`conflict.rule_arrays`, so the rules themselves stay data in `conflict.py`).

numba caches a compiled function by its own file only. Each kernel module therefore names the
fingerprint of this file it was written against (`PARTS_SHA256`), and
`test_consensus_kernel_parts.py` keeps them equal: a change here changes both kernel files
too, and numba recompiles them instead of reusing code built from the old parts.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

EPS = 1e-9  # the latest-start tolerance of `scoring._EPS`
NONE = -1
# rows of `tasks`
WS, WE, DUR, REF, REW, DISC = 0, 1, 2, 3, 4, 5
# 1.0 when every score is the paper's linear reward - ((start - ref) + duration) (the same
# in every column): a delay d then costs exactly d, and `Problem.gain_bound` is its bound
LIN = 6
# rows of the per-path work array (what `gains.PathGains.__init__` computes)
READY, CUM, OLD, LAM, ROOM = 0, 1, 2, 3, 4


@njit(cache=True)
def prepare(at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray, speed: float,
            avail: float, path: np.ndarray, times: np.ndarray, n_path: int,
            work: np.ndarray, pos_of: np.ndarray) -> bool:
    """What `gains.PathGains.__init__` computes once per path (and each task's position on
    it, -1 when absent); returns its `_late`."""
    for j in range(pos_of.shape[0]):
        pos_of[j] = -1
    work[READY, 0] = avail
    total_wait = 0.0
    late = False
    for n in range(n_path):
        j = path[n]
        pos_of[j] = n
        t = times[n]
        if n == 0:
            d = at_row[j]
        else:
            d = tt[path[n - 1], j]
        wait = t - (work[READY, n] + d / speed)
        total_wait += wait if wait > 0.0 else 0.0
        work[CUM, n] = total_wait
        dj = tasks[DISC, j]
        work[OLD, n] = tasks[REW, j] * math.exp(-dj * (t - tasks[REF, j]))
        work[LAM, n] = dj
        room = tasks[WE, j] - t + EPS
        work[ROOM, n] = room
        if room < 0.0:
            late = True
        work[READY, n + 1] = t + tasks[DUR, j]
    return late


@njit(cache=True)
def gain(c: int, not_before: float, at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray,
         pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float, path: np.ndarray,
         times: np.ndarray, n_path: int, late: bool, work: np.ndarray, pos_of: np.ndarray
         ) -> tuple[float, int]:
    """`gains.PathGains._evaluate`: (best gain, its position) of inserting task c, starting
    no earlier than `not_before` (CBBA's agents start at 0)."""
    lower = not_before
    first = 0
    if pre_ptr[c + 1] > pre_ptr[c]:
        # after every prerequisite, which must all be on the path
        last = -1
        done = -math.inf
        for e in range(pre_ptr[c], pre_ptr[c + 1]):
            q = pre_idx[e]
            if pos_of[q] < 0:
                return -math.inf, 0
            if pos_of[q] > last:
                last = pos_of[q]
            f = times[pos_of[q]] + tasks[DUR, q]
            if f > done:
                done = f
        first = last + 1
        if done > lower:
            lower = done
    w_s = tasks[WS, c]
    w_e = tasks[WE, c] + EPS
    d_c = tasks[DUR, c]
    ref_c = tasks[REF, c]
    rew_c = tasks[REW, c]
    disc_c = tasks[DISC, c]
    linear = tasks[LIN, c] > 0.0
    best = -math.inf
    at = 0
    for q in range(first, n_path + 1):
        r = work[READY, q]
        if r > w_e:
            break
        if q == 0:
            d = at_row[c]
        else:
            d = tt[path[q - 1], c]
        start = r + d / speed
        if start < w_s:
            start = w_s
        if start < lower:
            start = lower
        if start > w_e:
            continue
        if linear:
            total = rew_c - d_c - (start - ref_c)
        else:
            total = rew_c * math.exp(-disc_c * (start - ref_c))
        if total <= best:
            continue
        if q < n_path:
            d0 = start + d_c + tt[path[q], c] / speed - times[q]
            if d0 > 0.0:
                if late:
                    continue
                if d0 > work[ROOM, q]:
                    continue
                if linear:
                    change = -d0
                else:
                    change = work[OLD, q] * math.expm1(-work[LAM, q] * d0)
                base = work[CUM, q]
                feasible = True
                for k in range(q + 1, n_path):
                    delay = d0 - (work[CUM, k] - base)
                    if delay <= 0.0:
                        break
                    if delay > work[ROOM, k]:
                        feasible = False
                        break
                    if linear:
                        change -= delay
                    else:
                        change += work[OLD, k] * math.expm1(-work[LAM, k] * delay)
                if not feasible:
                    continue
                total += change
        if total > best:
            best = total
            at = q
    return best, at


@njit(cache=True)
def conflict_action(i: int, k: int, yi: float, zi: int, yk: float, zk: int, s: np.ndarray,
                    s_k: np.ndarray, table: np.ndarray, lut: np.ndarray) -> int:
    """Receiver i's action on one task given sender k's (yk, zk) and its own (yi, zi): 0 leave,
    1 update, 2 reset (`conflict.Action`). s and s_k are the timestamp rows, whose last entry
    (-inf) stands for "no winner"."""
    n = s.shape[0] - 1
    if zk == k:
        sc = 0
    elif zk == i:
        sc = 1
    elif zk == NONE:
        sc = 3
    else:
        sc = 2
    if zi == i:
        rc = 0
    elif zi == k:
        rc = 1
    elif zi == NONE:
        rc = 4
    elif sc == 2 and zi != zk:
        rc = 3
    else:
        rc = 2
    zk_at = zk if zk >= 0 else n
    zi_at = zi if zi >= 0 else n
    sk_zk = s_k[zk_at]
    si_zk = s[zk_at]
    beats = yk > yi or (yk == yi and zk != NONE and (zi == NONE or zk < zi))
    code = ((1 if beats else 0) + (2 if sk_zk > si_zk else 0)
            + (4 if s_k[zi_at] > s[zi_at] else 0) + (8 if si_zk > sk_zk else 0))
    return int(lut[table[sc, rc], code])


@njit(cache=True)
def earliest_start(j: int, prev: int, ready: float, at_row: np.ndarray, tt: np.ndarray,
                   tasks: np.ndarray, pre_ptr: np.ndarray, pre_idx: np.ndarray, speed: float,
                   finish: np.ndarray) -> tuple[float, bool]:
    """When task j can start on a path, after `prev` (-1: from the agent's position) done at
    `ready`: travel, then its window's start, then its prerequisites' finish times in
    `finish` (nan: not on the path before it, which makes it infeasible: False)."""
    if prev < 0:
        start = ready + at_row[j] / speed
    else:
        start = ready + tt[prev, j] / speed
    if tasks[WS, j] > start:
        start = tasks[WS, j]
    ok = True
    for e in range(pre_ptr[j], pre_ptr[j + 1]):
        f = finish[pre_idx[e]]
        if math.isnan(f):
            ok = False
        elif f > start:
            start = f
    return start, ok


@njit(cache=True)
def merge_stamps(s: np.ndarray, s_k: np.ndarray, k: int, i: int, now: float) -> None:
    """`cbba.merge_timestamps` of receiver i from sender k's stamps s_k at `now`; the last
    entry stays -inf (it stands for "no winner")."""
    n = s.shape[0] - 1
    for q in range(n):
        if s_k[q] > s[q]:
            s[q] = s_k[q]
    s[k] = now
    if now > s[i]:
        s[i] = now
    s[n] = -math.inf
