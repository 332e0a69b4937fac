"""CBBA (Choi, Brunet & How 2009): bundle construction and consensus for single-agent tasks.

Bids are warped: a task's bid is capped at the bid of the task added before it, so that bids
fall along the bundle even when scores are not diminishing (time windows make them rise at
times); this keeps consensus convergent and changes nothing when scores have diminishing
marginal gains.

An agent holds winning bids y (M,), winners z (M,) (-1 = none), timestamps s (N + 1,) whose
last entry stays -inf (looked up for "no winner"), its bundle (insertion order), its path
(execution order) and the path's start times. The arrays may be rows of larger arrays owned by
a runner, which then resolves many receivers at once with `consensus_batch`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from murdoch.consensus.conflict import NONE, apply_actions, resolve_many
from murdoch.consensus.messages import KIND_CBBA, ConsensusMessage
from murdoch.consensus.scoring import Problem, insertion_gains_batch, path_times


def new_timestamps(n_agents: int) -> np.ndarray:
    return np.full(n_agents + 1, -np.inf)


class BundleBuilding:
    """Phase 1 entry points shared by the CBBA and CBGA agents (see `build_bundles`)."""

    problem: Problem
    bundle: list[int]
    needs_build: bool
    active: bool
    _blocked: np.ndarray

    def build_bundle(self, now: float = 0.0) -> bool:
        """Add tasks greedily while a valid bid exists; True if the bundle grew."""
        before = len(self.bundle)
        build_bundles([self], now)  # type: ignore[list-item]
        return len(self.bundle) > before

    def start_build(self) -> bool:
        """Begin a bundle construction; False when there is nothing to do."""
        if not self.needs_build or not self.active:
            return False
        self.needs_build = False
        self._blocked = np.zeros(self.problem.n_tasks, dtype=bool)
        return True


class CbbaAgent(BundleBuilding):
    """One agent's CBBA state and its two phases."""

    kind = KIND_CBBA

    def __init__(self, problem: Problem, index: int, y: np.ndarray | None = None,
                 z: np.ndarray | None = None, s: np.ndarray | None = None) -> None:
        self.problem = problem
        self.index = index
        self.y = np.zeros(problem.n_tasks) if y is None else y
        self.z = np.full(problem.n_tasks, NONE, dtype=np.int64) if z is None else z
        self.s = new_timestamps(problem.n_agents) if s is None else s
        self.bundle: list[int] = []
        self.path: list[int] = []
        self.times = np.zeros(0)
        self.needs_build = True
        self.active = True

    # -- phase 1 ------------------------------------------------------------------------
    def candidates(self) -> np.ndarray | None:
        """Tasks to evaluate for the next insertion, or None when the bundle is complete."""
        if len(self.bundle) >= self.problem.max_depth:
            return None
        cand = self.problem.eligible[self.index] & ~self._blocked
        cand &= self.problem.gain_bound[self.index] >= self.y
        cand[self.bundle] = False
        return cand if cand.any() else None

    def not_before(self) -> np.ndarray | None:
        return None

    def take(self, gains: np.ndarray, pos: np.ndarray, now: float) -> bool:
        """Insert the best valid task; False when no valid bid remains."""
        i = self.index
        if self.bundle:
            gains = np.minimum(gains, self.y[self.bundle[-1]])
        valid = (gains > 0) & ((gains > self.y) | ((gains == self.y)
                                                   & ((self.z > i) | (self.z == i))))
        if not valid.any():
            return False
        j = int(np.argmax(np.where(valid, gains, -np.inf)))
        if not self._insert(j, int(pos[j])):
            self._blocked[j] = True
            return True
        self.y[j] = gains[j]
        self.z[j] = i
        return True

    @staticmethod
    def take_many(agents: Sequence[CbbaAgent], gains: np.ndarray, pos: np.ndarray,
                  now: float) -> list[bool]:
        """`take` for several agents, with the bid validity evaluated for all at once."""
        idx = np.array([a.index for a in agents])[:, None]
        y = np.stack([a.y for a in agents])
        z = np.stack([a.z for a in agents])
        cap = np.array([a.y[a.bundle[-1]] if a.bundle else np.inf for a in agents])
        gains = np.minimum(gains, cap[:, None])
        valid = (gains > 0) & ((gains > y) | ((gains == y) & (z >= idx)))
        best = np.argmax(np.where(valid, gains, -np.inf), axis=1)
        has = valid[np.arange(len(agents)), best]
        out = []
        for n, a in enumerate(agents):
            if not has[n]:
                out.append(False)
                continue
            j = int(best[n])
            if a._insert(j, int(pos[n, j])):
                a.y[j] = gains[n, j]
                a.z[j] = a.index
            else:
                a._blocked[j] = True
            out.append(True)
        return out

    def _insert(self, j: int, position: int) -> bool:
        path = [*self.path[:position], j, *self.path[position:]]
        times, ok = path_times(self.problem, self.index, path)
        if not ok:
            return False
        self.path = path
        self.times = times
        self.bundle.append(j)
        return True

    # -- phase 2 ------------------------------------------------------------------------
    def message(self, now: float) -> ConsensusMessage:
        s = self.s[:-1].copy()
        s[self.index] = now
        has = np.flatnonzero(self.z != NONE)
        return ConsensusMessage(
            self.kind, self.index, float(now),
            tuple((int(j), int(self.z[j]), float(self.y[j])) for j in has),
            tuple(float(x) for x in s))

    def receive(self, msg: ConsensusMessage, now: float,
                tasks: tuple[int, int] | None = None, merge: bool = True) -> bool:
        """Apply one neighbour's message (or the part of it covering tasks [first, end));
        True if y or z changed. With merge=False the timestamps are left for
        `merge_stamps`, so that several parts of one message compare against the same ones."""
        if not self.active or msg.sender == self.index:
            return False
        s_k = message_stamps(msg, self.s.size)
        if s_k is None:
            return False
        y_k = np.zeros(self.problem.n_tasks)
        z_k = np.full(self.problem.n_tasks, NONE, dtype=np.int64)
        for j, m, b in msg.entries:
            if 0 <= j < self.problem.n_tasks and 0 <= m < self.problem.n_agents:
                y_k[j] = b
                z_k[j] = m
        y_i = self.y[None, :].copy()
        z_i = self.z[None, :].copy()
        actions = resolve_many(np.array([self.index]), np.array([msg.sender]), y_k[None, :],
                               z_k[None, :], y_i, z_i, s_k[None, :], self.s[None, :])
        if tasks is not None:
            inside = np.zeros(self.problem.n_tasks, dtype=bool)
            inside[tasks[0]:tasks[1]] = True
            actions[0, ~inside] = 0
        apply_actions(actions, y_i, z_i, y_k[None, :], z_k[None, :])
        changed = bool((y_i[0] != self.y).any() or (z_i[0] != self.z).any())
        self.y[:] = y_i[0]
        self.z[:] = z_i[0]
        if merge:
            merge_timestamps(self.s, s_k, self.index, msg.sender, now)
        if changed:
            self.needs_build = True
        return changed

    def merge_stamps(self, msg: ConsensusMessage, now: float) -> None:
        s_k = message_stamps(msg, self.s.size)
        if s_k is not None and msg.sender != self.index:
            merge_timestamps(self.s, s_k, self.index, msg.sender, now)

    def release_outbid(self) -> bool:
        """Drop the first bundle task this agent no longer wins and every task after it."""
        i = self.index
        for n, j in enumerate(self.bundle):
            if self.z[j] != i:
                self._release_from(n, keep_first=True)
                return True
        return False

    def _release_from(self, n: int, keep_first: bool) -> None:
        released = self.bundle[n:]
        later = released[1:] if keep_first else released
        for j in later:
            self.y[j] = 0.0
            self.z[j] = NONE
        self.bundle = self.bundle[:n]
        drop = set(released)
        self.path = [j for j in self.path if j not in drop]
        self.times, _ = path_times(self.problem, self.index, self.path)
        self.needs_build = True

    def forget_agent(self, gone: int) -> None:
        """Another agent has left: its bids no longer hold."""
        lost = self.z == gone
        if lost.any():
            self.y[lost] = 0.0
            self.z[lost] = NONE
            self.needs_build = True

    def winners_view(self) -> list[frozenset[int]]:
        return [frozenset() if z == NONE else frozenset((int(z),)) for z in self.z]


class Builder(Protocol):
    problem: Problem
    index: int
    path: list[int]
    times: np.ndarray

    def start_build(self) -> bool: ...
    def candidates(self) -> np.ndarray | None: ...
    def not_before(self) -> np.ndarray | None: ...

    @staticmethod
    def take_many(agents: Sequence[Any], gains: np.ndarray, pos: np.ndarray,
                  now: float) -> list[bool]: ...


def build_bundles(agents: Sequence[Builder], now: float) -> None:
    """Phase 1 for several agents in lock step: one batched gain evaluation per insertion."""
    todo = [a for a in agents if a.start_build()]
    while todo:
        keep: list[Builder] = []
        cands: list[np.ndarray] = []
        for a in todo:
            c = a.candidates()
            if c is not None:
                keep.append(a)
                cands.append(c)
        if not keep:
            return
        bounds = [a.not_before() for a in keep]
        gains, pos = insertion_gains_batch(
            keep[0].problem, [a.index for a in keep], [a.path for a in keep],
            [a.times for a in keep], np.stack(cands),
            None if all(b is None for b in bounds) else np.stack(
                [np.zeros(keep[0].problem.n_tasks) if b is None else b for b in bounds]))
        go_on = type(keep[0]).take_many(keep, gains, pos, now)
        todo = [a for a, more in zip(keep, go_on, strict=True) if more]


def message_stamps(msg: ConsensusMessage, size: int) -> np.ndarray | None:
    """The sender's timestamps as an (N + 1,) row (sender's own = send time), or None when
    the message was made for a different number of agents."""
    s_k = np.append(np.asarray(msg.stamps, dtype=float), -np.inf)
    if s_k.size != size or not 0 <= msg.sender < size - 1:
        return None
    s_k[msg.sender] = max(s_k[msg.sender], msg.time)
    return s_k


def merge_timestamps(s_i: np.ndarray, s_k: np.ndarray, i: int, k: int, now: float) -> None:
    """s_in = max(s_in, s_kn) for every n, then s_ik = now (the last entry stays -inf)."""
    np.maximum(s_i, s_k, out=s_i)
    s_i[k] = now
    s_i[i] = max(s_i[i], now)
    s_i[-1] = -np.inf


def consensus_batch(receivers: np.ndarray, senders: np.ndarray, y: np.ndarray, z: np.ndarray,
                    s: np.ndarray, y_msg: np.ndarray, z_msg: np.ndarray, s_msg: np.ndarray,
                    now: float) -> np.ndarray:
    """One message per receiver at once (receivers distinct). y, z, s are the runner's (N, ...)
    arrays, *_msg the senders' values at send time. Returns the receivers whose y/z changed."""
    y_i = y[receivers]
    z_i = z[receivers]
    y_k = y_msg[senders]
    z_k = z_msg[senders]
    s_k = s_msg[senders].copy()
    s_k[np.arange(len(senders)), senders] = now
    # equal beliefs never change anything (only timestamps move): resolve only the
    # receivers whose message differs from what they hold
    rows = np.flatnonzero(((z_k != z_i) | (y_k != y_i)).any(axis=1))
    changed = np.zeros(len(receivers), dtype=bool)
    if rows.size:
        r_i = receivers[rows]
        y_r, z_r, y_kr, z_kr = y_i[rows], z_i[rows], y_k[rows], z_k[rows]
        actions = resolve_many(r_i, senders[rows], y_kr, z_kr, y_r, z_r, s_k[rows], s[r_i])
        apply_actions(actions, y_r, z_r, y_kr, z_kr)
        changed[rows] = ((y_r != y[r_i]) | (z_r != z[r_i])).any(axis=1)
        y[r_i] = y_r
        z[r_i] = z_r
    s_new = np.maximum(s[receivers], s_k)
    s_new[np.arange(len(senders)), senders] = now
    s_new[np.arange(len(receivers)), receivers] = np.maximum(
        s_new[np.arange(len(receivers)), receivers], now)
    s_new[:, -1] = -np.inf
    s[receivers] = s_new
    return receivers[changed]
