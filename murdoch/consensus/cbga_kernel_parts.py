"""What the compiled CBGA run's phases share: copies, bit counts, partners' times, path start
times against the partners, the times an agent publishes, group ranking and selection,
completeness, and path edits (see `cbga_kernel`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.kernel_parts import DUR, EPS, WE, WS

SOURCES_SHA256 = {
    "kernel_parts.py": "48acf80e0cde01c59b7422d086ad54ef9789e4fcdad8d5835d7b9ab48604f2af",
}
"""The kernel files this module's compiled code was built from (see `kernel_parts`)."""


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
def _remove(path: np.ndarray, plen: np.ndarray, i: int, drop: np.ndarray) -> None:
    kept = 0
    for q in range(plen[i]):
        if not drop[path[q]]:
            path[kept] = path[q]
            kept += 1
    plen[i] = kept


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
