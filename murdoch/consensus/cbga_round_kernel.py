"""The compiled CBGA run's bookkeeping around its phases (`cbga_kernel.run_cbga`).

The run's state arrays, what one round of messages costs (`CbgaAgent.sent_counts`), whether
anything that `comm_steps` watches changed over a round, and whether an agent still has a
group task to quit. The layout of the arrays is the one `cbga_kernel` describes.

`cbga_kernel` compiles these functions into its run, and numba caches a compiled function by
its own file only, so `cbga_kernel.ROUND_SHA256` names the fingerprint of this file and
`test_consensus_kernel_parts.py` keeps it current.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from murdoch.consensus.cbga_build_kernel import _complete, _copy
from murdoch.consensus.kernel_parts import bundles_changed, count_sends, remember_bundles

PARTS_SHA256 = "faf09f64dff8c2f95bf3bd53767118afd737e73822b364b9c8ad27114769815b"
"""The `kernel_parts.py` this module was written against (see its notes on numba's cache)."""


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


@njit(cache=True, inline="always")
def _lists(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                      np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every agent's winning bids X, members' times T, timestamps, bundle, path and its
    times, and whether it must (re)build: all empty."""
    return (np.zeros((n, m, n)), np.zeros((n, m, n)), np.full((n, n + 1), -math.inf),
            np.zeros((n, m), dtype=np.int64), np.zeros(n, dtype=np.int64),
            np.zeros((n, m + 1), dtype=np.int64), np.zeros((n, m + 1)),
            np.zeros(n, dtype=np.int64), np.ones(n, dtype=np.bool_))


@njit(cache=True, inline="always")
def _group_state(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                           np.ndarray, np.ndarray]:
    """Per agent and task: when it was assigned, the ban on re-bidding and quits counted;
    per agent: the task it yields to, the yielded tasks and to whom."""
    return (np.full((n, m), np.nan), np.full((n, m), -1, dtype=np.int64),
            np.zeros((n, m), dtype=np.int64), np.full(n, -1, dtype=np.int64),
            np.zeros((n, m), dtype=np.bool_), np.zeros((n, m, n), dtype=np.bool_))


@njit(cache=True, inline="always")
def _gain_cache(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each agent's last insertion gain per task: value, position, partners' time, valid."""
    return (np.zeros((n, m)), np.zeros((n, m), dtype=np.int64), np.zeros((n, m)),
            np.zeros((n, m), dtype=np.bool_))


@njit(cache=True, inline="always")
def _merge_scratch(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                     np.ndarray]:
    return (np.zeros(n, dtype=np.bool_), np.zeros(n), np.zeros(n), np.zeros(n, dtype=np.int64),
            np.zeros(n, dtype=np.bool_))


@njit(cache=True, inline="always")
def _remember(x: np.ndarray, t: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
              x_before: np.ndarray, t_before: np.ndarray, b_before: np.ndarray,
              blen_before: np.ndarray) -> None:
    """Keep X, T and the bundles as the round begins (for `_round_changed`)."""
    _copy(x_before, x)
    _copy(t_before, t)
    remember_bundles(bundle, blen, b_before, blen_before)


@njit(cache=True, inline="always")
def _stamp_sent(s: np.ndarray, s_sent: np.ndarray, now: float) -> None:
    """The timestamps each agent sends: its own, with itself heard now."""
    for i in range(s.shape[0]):
        for q in range(s.shape[1]):
            s_sent[i, q] = s[i, q]
        s_sent[i, i] = now


@njit(cache=True, inline="always")
def _any_pending_quit(x: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
                      assigned_at: np.ndarray, quit_after: np.ndarray, single: np.ndarray,
                      required: np.ndarray, task_eq: np.ndarray, agent_eq: np.ndarray) -> bool:
    """Some agent still has a group task it would quit."""
    for i in range(x.shape[0]):
        if _pending_quit(x[i], bundle[i], blen[i], assigned_at[i], quit_after, single,
                         required, task_eq, agent_eq):
            return True
    return False


@njit(cache=True, inline="always")
def _round_cost(x: np.ndarray, t: np.ndarray, x_sent: np.ndarray, t_sent: np.ndarray,
                out_degree: np.ndarray, single: np.ndarray, msg_base: int,
                msg_entry: int, tally: np.ndarray) -> None:
    """What the round's messages cost (`CbgaAgent.sent_counts`), counted into the tally
    (`count_sends`): pairwise steps are the messages of senders whose lists changed since
    their last round."""
    n, m = x.shape[0], x.shape[1]
    entries = np.zeros(n, dtype=np.int64)  # its non-zero bids and members' times
    changed = np.zeros(n, dtype=np.bool_)
    for k in range(n):
        if out_degree[k] == 0:
            continue
        for j in range(m):
            for q in range(n):
                if x[k, j, q] != 0.0:
                    entries[k] += 1
                    if not single[j] and t[k, j, q] > 0.0 and x[k, j, q] > 0.0:
                        entries[k] += 1
        changed[k] = _sent_changed(k, x, t, x_sent, t_sent, single)
    count_sends(out_degree, entries, changed, msg_base, msg_entry, tally)


@njit(cache=True, inline="always")
def _round_changed(x: np.ndarray, t: np.ndarray, bundle: np.ndarray, blen: np.ndarray,
                   x_before: np.ndarray, t_before: np.ndarray, b_before: np.ndarray,
                   blen_before: np.ndarray) -> bool:
    """Did anything that comm_steps watches (X, T, bundles) change over the round?"""
    if bundles_changed(bundle, blen, b_before, blen_before):
        return True
    n, m = x.shape[0], x.shape[1]
    for i in range(n):
        for j in range(m):
            for q in range(n):
                if x[i, j, q] != x_before[i, j, q] or t[i, j, q] != t_before[i, j, q]:
                    return True
    return False
