"""CBBA (Choi, Brunet & How 2009): bundle construction and consensus for single-agent tasks.

Bids are warped: a task's bid is capped at the bid of the task added before it, so that bids
fall along the bundle even when scores are not diminishing (time windows make them rise at
times); this keeps consensus convergent and changes nothing when scores have diminishing
marginal gains.

An agent holds winning bids y (M,), winners z (M,) (-1 = none), timestamps s (N + 1,) whose
last entry stays -inf (looked up for "no winner"), its bundle (insertion order), its path
(execution order) and the path's start times, all as plain lists: the problems are small and
per-element Python is cheaper than array calls here. Marginal gains are cached per path
(`gains.PathGains`), so rebuilding a bundle whose path did not change costs only the tasks
not yet evaluated.
"""

from __future__ import annotations

import math

from murdoch.consensus.conflict import NONE, resolve_lists
from murdoch.consensus.gains import PathGains
from murdoch.consensus.messages import KIND_CBBA, ConsensusMessage
from murdoch.consensus.scoring import Problem, path_starts

_KNOWN_PATHS = 256  # gains of this many paths are kept per agent


def new_timestamps(n_agents: int) -> list[float]:
    return [-math.inf] * (n_agents + 1)


class BundleBuilding:
    """Phase 1 shared by the CBBA and CBGA agents: add the best valid task until none is
    left or the bundle is full (`_add_best` is the algorithm's choice of one task)."""

    problem: Problem
    index: int
    bundle: list[int]
    path: list[int]
    times: list[float]
    needs_build: bool
    active: bool
    _blocked: list[bool]
    _gains: PathGains | None
    _bounds: dict[int, tuple[float, float]] | None = None
    _known_paths: dict[tuple[tuple[int, ...], tuple[float, ...]], PathGains]

    def _init_agent(self, problem: Problem, index: int) -> None:
        """The state both agents start with: no bundle, nothing heard yet."""
        self.problem = problem
        self.index = index
        self.s = new_timestamps(problem.n_agents)
        self.bundle = []
        self.path = []
        self.times = []
        self._gains = None
        self._known_paths = {}
        self._blocked = []
        self.needs_build = True
        self.active = True

    def build_bundle(self, now: float = 0.0) -> bool:
        """Add tasks greedily while a valid bid exists; True if the bundle grew."""
        if not self.start_build():
            return False
        before = len(self.bundle)
        limit = self.problem.max_depth
        while len(self.bundle) < limit and self._add_best(now):
            pass
        return len(self.bundle) > before

    def start_build(self) -> bool:
        """Begin a bundle construction; False when there is nothing to do."""
        if not self.needs_build or not self.active:
            return False
        self.needs_build = False
        self._blocked = [False] * self.problem.n_tasks
        return True

    def _add_best(self, now: float) -> bool:
        raise NotImplementedError

    def path_gains(self) -> PathGains:
        """The insertion gains of the current path (kept until the path changes; paths
        met again after a release are looked up)."""
        if self._gains is None:
            key = (tuple(self.path), tuple(self.times))
            known = self._known_paths
            gains = known.get(key)
            if gains is None:
                if len(known) >= _KNOWN_PATHS:
                    known.clear()
                gains = known[key] = PathGains(self.problem, self.index, self.path,
                                               self.times, self._bounds)
            self._gains = gains
            self._bounds = None
        return self._gains

    def _set_path(self, path: list[int], times: list[float], grown: bool = False) -> None:
        """A new path; `grown` when it is the old one with a task inserted. What bounds the
        old path's gains bounds the new one's when no task starts earlier than before
        (checked: group tasks may start earlier when partners' times changed since)."""
        self._bounds = None
        if grown and self._gains is not None and _no_earlier(self.path, self.times, path,
                                                            times):
            self._bounds = self._gains.bounds()
        self.path = path
        self.times = times
        self._gains = None

    def _forget_paths(self) -> None:
        """The problem changed: no cached gains hold."""
        self._known_paths = {}
        self._gains = None


def _no_earlier(old_path: list[int], old_times: list[float], path: list[int],
                times: list[float]) -> bool:
    """Whether every task of old_path starts no earlier on path (a superset in the same
    order)."""
    k = 0
    for j, t in zip(path, times, strict=True):
        if k < len(old_path) and j == old_path[k]:
            if t < old_times[k]:
                return False
            k += 1
    return True


class CbbaAgent(BundleBuilding):
    """One agent's CBBA state and its two phases."""

    kind = KIND_CBBA

    def __init__(self, problem: Problem, index: int) -> None:
        self._init_agent(problem, index)
        self.y: list[float] = [0.0] * problem.n_tasks
        self.z: list[int] = [NONE] * problem.n_tasks

    def state_key(self) -> tuple[tuple[float, ...], tuple[int, ...], tuple[int, ...]]:
        """What `comm_steps` watches: bids, winners and bundle."""
        return tuple(self.y), tuple(self.z), tuple(self.bundle)

    # -- phase 1 ------------------------------------------------------------------------
    def _add_best(self, now: float) -> bool:
        """Insert the best valid task; False when no valid bid remains."""
        lst = self.problem.lists
        i = self.index
        y, z, blocked = self.y, self.z, self._blocked
        bound = lst.gain_bound[i]
        eligible = lst.eligible[i]
        held = set(self.bundle)
        cap = y[self.bundle[-1]] if self.bundle else math.inf
        gains = self.path_gains()
        # candidates by their upper bound, highest first: once a bound is below the best
        # valid bid found, no later candidate can win (equal bids: the lower index wins)
        known = gains.bounds_known
        order = []
        for j in range(self.problem.n_tasks):
            yj = y[j]
            ub = bound[j]
            if not eligible[j] or blocked[j] or ub < yj or j in held:
                continue
            hit = known.get(j)  # (not-before time, bound): always 0 here
            if hit is not None and hit[1] < ub:
                ub = hit[1]
            if cap < ub:
                ub = cap
            if ub > 0.0 and ub >= yj:
                order.append((-ub, j))
        order.sort()
        best = -math.inf
        best_j = -1
        best_pos = 0
        for neg_ub, j in order:
            if -neg_ub < best:
                break
            if -neg_ub == best and j > best_j:
                continue
            g, pos = gains.gain(j)
            if g > cap:
                g = cap
            yj = y[j]
            if g > 0.0 and (g > yj or (g == yj and z[j] >= i)) and (
                    g > best or (g == best and j < best_j)):
                best, best_j, best_pos = g, j, pos
        if best_j < 0:
            return False
        if self._insert(best_j, best_pos):
            y[best_j] = best
            z[best_j] = i
        else:
            blocked[best_j] = True
        return True

    def _insert(self, j: int, position: int) -> bool:
        path = [*self.path[:position], j, *self.path[position:]]
        times, ok = path_starts(self.problem, self.index, path)
        if not ok:
            return False
        self._set_path(path, times, grown=True)
        self.bundle.append(j)
        return True

    # -- phase 2 ------------------------------------------------------------------------
    def sent_data(self) -> tuple[tuple[tuple[int, int, float], ...], tuple[()]]:
        """The allocation data `message` carries (its entries; no members' times), to tell
        a send that carries news from a repeat."""
        y = self.y
        return tuple((j, m, y[j]) for j, m in enumerate(self.z) if m != NONE), ()

    def message(self, now: float) -> ConsensusMessage:
        s = self.s[:-1]
        s[self.index] = now
        return ConsensusMessage(
            self.kind, self.index, float(now),
            tuple((j, m, self.y[j]) for j, m in enumerate(self.z) if m != NONE),
            tuple(s))

    def receive(self, msg: ConsensusMessage, now: float,
                tasks: tuple[int, int] | None = None, merge: bool = True) -> bool:
        """Apply one neighbour's message (or the part of it covering tasks [first, end));
        True if y or z changed. With merge=False the timestamps are left for
        `merge_stamps`, so that several parts of one message compare against the same ones."""
        if not self.active or msg.sender == self.index:
            return False
        s_k = message_stamps(msg, len(self.s))
        if s_k is None:
            return False
        m_tasks, n_agents = self.problem.n_tasks, self.problem.n_agents
        y_k = [0.0] * m_tasks
        z_k = [NONE] * m_tasks
        for j, m, b in msg.entries:
            if 0 <= j < m_tasks and 0 <= m < n_agents:
                y_k[j] = b
                z_k[j] = m
        first, end = (0, m_tasks) if tasks is None else tasks
        return self.apply(msg.sender, y_k, z_k, s_k, now, first, end, merge)

    def apply(self, k: int, y_k: list[float], z_k: list[int], s_k: list[float], now: float,
              first: int = 0, end: int | None = None, merge: bool = True) -> bool:
        """Resolve sender k's (y, z) for tasks [first, end) (s_k[k] must be the send time),
        then merge the timestamps; True if y or z changed."""
        changed = resolve_lists(self.index, k, self.y, self.z, self.s, y_k, z_k, s_k,
                                first, end)
        if merge:
            merge_timestamps(self.s, s_k, self.index, k, now)
        if changed:
            self.needs_build = True
        return changed

    def merge_stamps(self, msg: ConsensusMessage, now: float) -> None:
        s_k = message_stamps(msg, len(self.s))
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
        path = [j for j in self.path if j not in drop]
        self._set_path(path, path_starts(self.problem, self.index, path)[0])
        self.needs_build = True

    def forget_agent(self, gone: int) -> None:
        """Another agent has left: its bids no longer hold."""
        for j, m in enumerate(self.z):
            if m == gone:
                self.y[j] = 0.0
                self.z[j] = NONE
                self.needs_build = True

    def add_tasks(self, problem: Problem) -> None:
        """The problem grew by new tasks (appended): no bids on them yet."""
        extra = problem.n_tasks - self.problem.n_tasks
        self.problem = problem
        self.y.extend([0.0] * extra)
        self.z.extend([NONE] * extra)
        self._forget_paths()
        self.needs_build = True

    def winners_view(self) -> list[frozenset[int]]:
        return [frozenset() if z == NONE else frozenset((z,)) for z in self.z]


def message_stamps(msg: ConsensusMessage, size: int) -> list[float] | None:
    """The sender's timestamps as an (N + 1,) list (sender's own = send time, last -inf),
    or None when the message was made for a different number of agents."""
    if len(msg.stamps) + 1 != size or not 0 <= msg.sender < size - 1:
        return None
    s_k = [float(v) for v in msg.stamps]
    s_k.append(-math.inf)
    s_k[msg.sender] = max(s_k[msg.sender], msg.time)
    return s_k


def merge_timestamps(s_i: list[float], s_k: list[float], i: int, k: int, now: float) -> None:
    """s_in = max(s_in, s_kn) for every n, then s_ik = now (the last entry stays -inf)."""
    s_i[:] = map(max, s_i, s_k)
    s_i[k] = now
    if now > s_i[i]:
        s_i[i] = now
    s_i[-1] = -math.inf
