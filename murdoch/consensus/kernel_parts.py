"""What the compiled CBBA and CBGA runs share: task rows, path gains and the conflict table.

`cbba_kernel` and `cbga_kernel` restate the agents' code over arrays; the parts both need
are written once here: the layout of the task rows and of the per-path work array, the
gains of inserting a task into a path (`gains.PathGains`), CBBA's conflict rules applied
to one task (`conflict.resolve_lists`, with the table and look-up arrays of
`conflict.rule_arrays`, so the rules themselves stay data in `conflict.py`; `settle_task`
gives the resulting bid and winner), the winner read from a row of bids, the start times
along a path (`path_starts`, with CBGA's partners' times as lower bounds), the steps of
taking a task (insertion, commit of the timed path) and of releasing outbid ones (cut of
the bundle, removal from the path), and the round's bookkeeping (bundles changed, what the
sends cost, the tally of rounds that ends the run).

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
# entries of a run's round tally (`new_tally`): what was sent so far, the same through the
# last round that changed anything (what the run reports), that round, and the quiet rounds
# since it
SENT_MSGS, SENT_BYTES, SENT_PAIRS, MESSAGES, NBYTES, PAIRWISE, LAST_CHANGE, QUIET = range(8)


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
def _belief_code(z: int, own: int, other: int, nobody: int, another: int) -> int:
    """The code of believed winner z in the table's row or column (`conflict.SENDER_CODES`,
    `conflict.RECEIVER_CODES`): 0 for the believer itself (`own`), 1 for the other party,
    `nobody` for no winner and `another` for any other agent."""
    if z == own:
        return 0
    if z == other:
        return 1
    if z == NONE:
        return nobody
    return another


@njit(cache=True)
def conflict_action(i: int, k: int, yi: float, zi: int, yk: float, zk: int, s: np.ndarray,
                    s_k: np.ndarray, table: np.ndarray, lut: np.ndarray) -> int:
    """Receiver i's action on one task given sender k's (yk, zk) and its own (yi, zi): 0 leave,
    1 update, 2 reset (`conflict.Action`). s and s_k are the timestamp rows, whose last entry
    (-inf) stands for "no winner"."""
    n = s.shape[0] - 1
    sc = _belief_code(zk, k, i, 3, 2)
    # any other agent is "m" (2) to the receiver too, or "n" (3) when the sender believes
    # in a different other agent
    rc = _belief_code(zi, i, k, 4, 3 if sc == 2 and zi != zk else 2)
    zk_at = zk if zk >= 0 else n
    zi_at = zi if zi >= 0 else n
    sk_zk = s_k[zk_at]
    si_zk = s[zk_at]
    beats = yk > yi or (yk == yi and zk != NONE and (zi == NONE or zk < zi))
    code = ((1 if beats else 0) + (2 if sk_zk > si_zk else 0)
            + (4 if s_k[zi_at] > s[zi_at] else 0) + (8 if si_zk > sk_zk else 0))
    return int(lut[table[sc, rc], code])


@njit(cache=True)
def settle_task(i: int, k: int, yi: float, zi: int, yk: float, zk: int, s: np.ndarray,
                s_k: np.ndarray, table: np.ndarray, lut: np.ndarray) -> tuple[float, int, bool]:
    """Receiver i's (bid, winner) of one task after sender k's (yk, zk) under CBBA's rules
    (`conflict_action`), and whether that changed its own (yi, zi)."""
    if zk == zi and yk == yi:
        return yi, zi, False
    action = conflict_action(i, k, yi, zi, yk, zk, s, s_k, table, lut)
    if action == 1:
        return yk, zk, True
    if action == 2 and (yi != 0.0 or zi != NONE):
        return 0.0, NONE, True
    return yi, zi, False


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
def path_starts(at_row: np.ndarray, tt: np.ndarray, tasks: np.ndarray, pre_ptr: np.ndarray,
                pre_idx: np.ndarray, speed: float, avail: float, path: np.ndarray, n_path: int,
                lower: np.ndarray, out: np.ndarray, ready: np.ndarray) -> tuple[bool, int]:
    """`scoring.path_starts`: start times along the path (into `out`) after travel, window
    starts and prerequisites earlier on the path, and no earlier than each task's positive
    lower bound lower[j] (CBGA's partners' times; `ready` keeps each start before it);
    whether every start fits its window, and the first index that does not (-1)."""
    ok = True
    bad = -1
    r = avail
    prev = -1
    finish = np.full(tasks.shape[1], np.nan)  # nan: not (yet) on the path
    for n in range(n_path):
        j = path[n]
        start, fits = earliest_start(j, prev, r, at_row, tt, tasks, pre_ptr, pre_idx, speed,
                                     finish)
        if not fits:
            ok = False
        ready[n] = start
        lb = lower[j]
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


@njit(cache=True)
def row_winner(row: np.ndarray) -> tuple[float, int]:
    """The winner of a single-agent task read from its row of bids by agent (one non-zero
    entry at most): (its bid, its index), or (0.0, NONE) when there is none."""
    y = 0.0
    z = NONE
    for q in range(row.shape[0]):
        if row[q] > y:
            y = row[q]
            z = q
    return y, z


@njit(cache=True)
def held_tasks(i: int, bundle: np.ndarray, blen: np.ndarray, m: int) -> np.ndarray:
    """Which of the m tasks agent i's bundle holds (`bundle` is agent i's row)."""
    held = np.zeros(m, dtype=np.bool_)
    for b in range(blen[i]):
        held[bundle[b]] = True
    return held


@njit(cache=True)
def forget_gains(gain_ok: np.ndarray) -> None:
    """The agent's path changed: none of its cached insertion gains holds any more."""
    for j in range(gain_ok.shape[0]):
        gain_ok[j] = False


@njit(cache=True)
def insert_task(path: np.ndarray, n_path: int, pos: int, j: int, out: np.ndarray) -> None:
    """out[:n_path + 1] is the path with task j inserted at position pos."""
    for q in range(pos):
        out[q] = path[q]
    out[pos] = j
    for q in range(pos, n_path):
        out[q + 1] = path[q]


@njit(cache=True)
def commit_path(i: int, j: int, n_path: int, new_path: np.ndarray, new_times: np.ndarray,
                path: np.ndarray, times: np.ndarray, plen: np.ndarray, gain_ok: np.ndarray,
                bundle: np.ndarray, blen: np.ndarray, held: np.ndarray) -> None:
    """Agent i takes task j: the timed path with j inserted (n_path + 1 tasks in new_path,
    new_times) becomes its path and j joins the end of its bundle."""
    for q in range(n_path + 1):
        path[q] = new_path[q]
        times[q] = new_times[q]
    plen[i] = n_path + 1
    forget_gains(gain_ok)
    bundle[blen[i]] = j
    blen[i] += 1
    held[j] = True


@njit(cache=True)
def remove_marked(path: np.ndarray, plen: np.ndarray, i: int, drop: np.ndarray) -> None:
    """Take the tasks marked in `drop` off agent i's path (or bundle: `path` and `plen` are
    then its bundle and bundle lengths), keeping the others' order."""
    kept = 0
    for q in range(plen[i]):
        if not drop[path[q]]:
            path[kept] = path[q]
            kept += 1
    plen[i] = kept


@njit(cache=True)
def cut_bundle(i: int, b: int, bundle: np.ndarray, blen: np.ndarray, path: np.ndarray,
               plen: np.ndarray, m: int) -> None:
    """The release of an outbid task: agent i's bundle ends before position b, and the tasks
    cut from it leave its path (the caller resets the bids and re-times the path)."""
    drop = np.zeros(m, dtype=np.bool_)
    for r in range(b, blen[i]):
        drop[bundle[r]] = True
    blen[i] = b
    remove_marked(path, plen, i, drop)


@njit(cache=True)
def remember_bundles(bundle: np.ndarray, blen: np.ndarray, b_before: np.ndarray,
                     blen_before: np.ndarray) -> None:
    """Keep every agent's bundle as the round begins (for `bundles_changed`)."""
    for i in range(blen.shape[0]):
        blen_before[i] = blen[i]
        for b in range(blen[i]):
            b_before[i, b] = bundle[i, b]


@njit(cache=True)
def bundles_changed(bundle: np.ndarray, blen: np.ndarray, b_before: np.ndarray,
                    blen_before: np.ndarray) -> bool:
    """Whether some agent's bundle differs from the one `remember_bundles` kept."""
    for i in range(blen.shape[0]):
        if blen[i] != blen_before[i]:
            return True
        for b in range(blen[i]):
            if bundle[i, b] != b_before[i, b]:
                return True
    return False


@njit(cache=True)
def new_tally() -> np.ndarray:
    """A run's round tally before its first round: nothing sent, no round yet."""
    return np.zeros(8, dtype=np.int64)


@njit(cache=True)
def count_sends(out_degree: np.ndarray, entries: np.ndarray, changed: np.ndarray,
                msg_base: int, msg_entry: int, tally: np.ndarray) -> None:
    """What one round of sends costs, added to the tally: every agent k sends its message
    to its out_degree[k] neighbours, msg_base + entries[k] * msg_entry bytes each, and those
    messages count as pairwise steps when its message changed since its last round
    (changed[k])."""
    for k in range(out_degree.shape[0]):
        d = out_degree[k]
        if d == 0:
            continue
        tally[SENT_MSGS] += d
        tally[SENT_BYTES] += d * (msg_base + entries[k] * msg_entry)
        if changed[k]:
            tally[SENT_PAIRS] += d


@njit(cache=True)
def close_round(tally: np.ndarray, rnd: int, changed: bool) -> None:
    """The end of round `rnd`: when it changed anything that comm_steps watches, what was
    sent so far is what the run reports, as of this round; otherwise one more quiet round."""
    if changed:
        tally[LAST_CHANGE] = rnd
        tally[MESSAGES] = tally[SENT_MSGS]
        tally[NBYTES] = tally[SENT_BYTES]
        tally[PAIRWISE] = tally[SENT_PAIRS]
        tally[QUIET] = 0
    else:
        tally[QUIET] += 1


@njit(cache=True)
def settled(tally: np.ndarray, diameter: int) -> bool:
    """Converged: the last diameter + 1 rounds changed nothing (every agent has heard every
    other's final lists)."""
    return tally[QUIET] >= diameter + 1


@njit(cache=True)
def reported(tally: np.ndarray) -> tuple[int, int, int, int]:
    """What the run reports: (comm_steps, the round of the last change; the messages, bytes
    and pairwise steps sent through it)."""
    return tally[LAST_CHANGE], tally[MESSAGES], tally[NBYTES], tally[PAIRWISE]
