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

Layout: `tasks` is (6, M): window start, latest start (raw), duration, score reference time,
reward, discount; task j's prerequisites are pre_idx[pre_ptr[j]:pre_ptr[j+1]]; equipment is
a bit mask per agent and per task. Agent i's beliefs are x[i] (M, N: bids, 0 = not a member)
and t[i] (M, N: when each member can be at a group task on its own, 0 = unknown), its
timestamps s[i] (N + 1, the last one -inf), its bundle (insertion order) and path (execution
order) with start times. Compiled on first use and cached on disk next to this module.

The run's parts are modules of their own: phase 1 in `cbga_build_kernel`, phase 2, quitting,
release and re-planning in `cbga_merge_kernel`, what both use in `cbga_kernel_parts`, and what
CBBA's kernel shares in `kernel_parts`. numba's on-disk cache of a function is invalidated by
changes to its own file only, so each module names the fingerprints of the kernel files it
calls into (`SOURCES_SHA256`), and `test_consensus_kernel_parts.py` keeps them current: a
change to a part changes the files that use it, and numba recompiles them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.cbga_build_kernel import _build
from murdoch.consensus.cbga_kernel_parts import _copy
from murdoch.consensus.cbga_merge_kernel import _any_pending_quit, _exchange, _quit, _replan
from murdoch.consensus.kernel_parts import EPS, WE

SOURCES_SHA256 = {
    "kernel_parts.py": "48acf80e0cde01c59b7422d086ad54ef9789e4fcdad8d5835d7b9ab48604f2af",
    "cbga_kernel_parts.py": "9ee7999199310d41f4d0269c6e20003f088cdaf282abee0f13f2fc072f4afa38",
    "cbga_build_kernel.py": "a025bc0c0212096bdd649beda46af2d0e8ad7aef24dd83e22a6f05bdd3e71c6c",
    "cbga_merge_kernel.py": "daf51a711b5ec7e0bbffcf4749e00dc2e807b0b8867babf91aac7730bf00798c",
}
"""The kernel files this module's compiled code was built from (see `kernel_parts`)."""


@njit(cache=True)
def _round_cost(x: np.ndarray, t: np.ndarray, single: np.ndarray, out_degree: np.ndarray,
                msg_base: int, msg_entry: int) -> tuple[int, int]:
    """The messages and bytes every agent sends to its neighbours this round
    (`CbgaAgent.sent_counts`)."""
    n, m = x.shape[0], x.shape[1]
    msgs = 0
    nbytes = 0
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
        msgs += d
        nbytes += d * (msg_base + (entries + n_starts) * msg_entry)
    return msgs, nbytes


@njit(cache=True)
def _changed(bundle: np.ndarray, blen: np.ndarray, b_before: np.ndarray,
             blen_before: np.ndarray, x: np.ndarray, x_before: np.ndarray, t: np.ndarray,
             t_before: np.ndarray) -> bool:
    """Whether anything `comm_steps` watches (bundles, X, T) changed over the round."""
    n, m = x.shape[0], x.shape[1]
    for i in range(n):
        if blen[i] != blen_before[i]:
            return True
        for b in range(blen[i]):
            if bundle[i, b] != b_before[i, b]:
                return True
    for i in range(n):
        for j in range(m):
            for q in range(n):
                if x[i, j, q] != x_before[i, j, q] or t[i, j, q] != t_before[i, j, q]:
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
             msg_entry: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int, int, int,
                                      bool]:
    """Synchronous CBGA to convergence. Returns (paths (N, M + 1), path lengths, every
    agent's X (N, M, N), rounds, comm_steps, messages, bytes, converged)."""
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
    messages = 0
    nbytes = 0
    rnd = 0
    last_change = 0
    quiet = 0
    while True:
        pending = quitting and _any_pending_quit(x, bundle, blen, assigned_at, quit_after,
                                                 single, required, task_eq, agent_eq)
        if (quiet >= diameter + 1 and not pending) or rnd >= max_rounds:
            break
        rnd += 1
        now = float(rnd)
        _copy(x_before, x)
        _copy(t_before, t)
        blen_before[:] = blen
        b_before[:, :] = bundle
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
                       task_eq, agent_eq, team, quit_limit, max_depth, work)
        # -- what the round's messages cost (`CbgaAgent.sent_counts`)
        round_msgs, round_bytes = _round_cost(x, t, single, out_degree, msg_base, msg_entry)
        sent_msgs += round_msgs
        sent_bytes += round_bytes
        # -- phase 2: everyone sends, then each merges its neighbours' messages in order
        _exchange(now, x, t, s, x_sent, t_sent, s_sent, nbr_ptr, nbr_idx, single, required,
                  task_eq, agent_eq, table, lut, known, row, starts, order, chosen, needs)
        # -- release what each agent was outbid on, then re-plan against its partners
        _replan(x, t, bundle, blen, path, times, plen, yielding, yielded, yset, gain_ok,
                at_dist, tt, tasks, pre_ptr, pre_idx, speed, avail, single, latest, groups,
                new_times, ready, needs)
        # -- did anything that comm_steps watches (X, T, bundles) change over the round?
        if _changed(bundle, blen, b_before, blen_before, x, x_before, t, t_before):
            last_change = rnd
            messages = sent_msgs
            nbytes = sent_bytes
            quiet = 0
        else:
            quiet += 1
    pending = quitting and _any_pending_quit(x, bundle, blen, assigned_at, quit_after, single,
                                             required, task_eq, agent_eq)
    converged = quiet >= diameter + 1 and not pending
    return path, plen, x, rnd, last_change, messages, nbytes, converged
