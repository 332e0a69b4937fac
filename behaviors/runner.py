"""Threads for behaviours: one thread per behaviour, one owner, one tick at a time.

`BehaviourRunner` owns its worker threads. Each tick the owner publishes the snapshot and
time and wakes the first worker; each worker wakes once, runs its behaviour's pure `decide`,
posts its proposal and wakes the next; the last one wakes the owner. (Under the GIL pure
Python behaviours cannot run in parallel anyway; passing the baton along costs one thread
switch per behaviour instead of a stampede.) A worker's only waiting point is also its only
cancellation point. An exception in a behaviour reaches the owner as `BehaviourFailed` from
the next `tick()`; a behaviour that does not answer within `stall_timeout_s` (wall time)
raises `BehaviourStalled`.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence

from behaviors.proposal import Behaviour, Proposal
from behaviors.snapshot import Snapshot

logger = logging.getLogger(__name__)


class BehaviourFailed(RuntimeError):
    def __init__(self, behaviour: str, error: BaseException) -> None:
        super().__init__(f"behaviour {behaviour!r} raised {error!r}")
        self.behaviour = behaviour
        self.error = error


class BehaviourStalled(RuntimeError):
    pass


class _Worker:
    """One behaviour's thread and its hand-off lock (used as a binary semaphore).

    Plain locks are the cheapest wake-up CPython has: `go` is released to start this
    worker's turn; when its proposal is posted it releases `after` (the next worker's `go`,
    or the owner's lock). Nothing is allocated per tick.
    """

    __slots__ = ("after", "behaviour", "error", "go", "index", "result", "thread")

    def __init__(self, index: int, behaviour: Behaviour) -> None:
        self.index = index
        self.behaviour = behaviour
        self.go = threading.Lock()
        self.go.acquire()
        self.after: threading.Lock = self.go
        self.result: Proposal | None = None
        self.error: BaseException | None = None
        self.thread: threading.Thread | None = None


class BehaviourRunner:
    """Owns one thread per behaviour of the current set; `tick()` runs them all once."""

    def __init__(self, name: str = "robot", stall_timeout_s: float = 10.0) -> None:
        self._name = name
        self._stall_timeout_s = stall_timeout_s
        self._workers: list[_Worker] = []
        self._stop = False
        self._snapshot: Snapshot | None = None
        self._now = 0.0
        self._results: list[Proposal] = []
        self._ticks = 0
        self._broken = False
        self._done = threading.Lock()
        self._done.acquire()

    @property
    def ticks(self) -> int:
        return self._ticks

    @property
    def thread_count(self) -> int:
        return sum(1 for w in self._workers if w.thread is not None and w.thread.is_alive())

    def set_behaviours(self, behaviours: Sequence[Behaviour]) -> None:
        """Replace the running set: stop and join the old threads, start new ones."""
        if not self._broken and len(behaviours) == len(self._workers) and all(
            w.behaviour is b for w, b in zip(self._workers, behaviours, strict=True)
        ):
            return
        self._stop_workers()
        self._stop = False
        self._broken = False
        self._workers = [_Worker(i, b) for i, b in enumerate(behaviours)]
        self._done = threading.Lock()
        self._done.acquire()
        for w, nxt in zip(self._workers, self._workers[1:], strict=False):
            w.after = nxt.go
        if self._workers:
            self._workers[-1].after = self._done
        self._results = [Proposal(False, weight=0.0)] * len(behaviours)
        for w in self._workers:
            w.thread = threading.Thread(
                target=self._work, args=(w,), name=f"{self._name}:{w.behaviour.name}",
                daemon=True,
            )
            w.thread.start()

    def tick(self, snapshot: Snapshot, now: float) -> list[Proposal]:
        """Run every behaviour once on `snapshot`; return the proposals in order.

        After `BehaviourStalled` the set is broken: the next `set_behaviours` replaces it.
        """
        workers = self._workers
        if not workers:
            return []
        if self._broken:
            raise BehaviourStalled("the behaviour set stalled earlier; replace it first")
        self._snapshot = snapshot
        self._now = now
        workers[0].go.release()
        if not self._done.acquire(timeout=self._stall_timeout_s):
            self._broken = True
            late = [w.behaviour.name for w in workers if w.result is None and w.error is None]
            raise BehaviourStalled(f"behaviours {late} did not answer in time")
        self._ticks += 1
        results = self._results
        failed: _Worker | None = None
        for w in workers:
            if w.error is not None and failed is None:
                failed = w
            results[w.index] = w.result  # type: ignore[assignment]
            w.result = None
        if failed is not None:
            error = failed.error
            for w in workers:
                w.error = None
            raise BehaviourFailed(failed.behaviour.name, error) from error  # type: ignore[arg-type]
        return results

    def _work(self, w: _Worker) -> None:
        behaviour = w.behaviour
        go = w.go
        after = w.after
        while True:
            go.acquire()  # the one waiting and cancellation point
            if self._stop:
                return
            try:
                w.result = behaviour.decide(self._snapshot, self._now)  # type: ignore[arg-type]
            except BaseException as exc:  # reported to the owner by tick()
                w.error = exc
            if self._stop:  # stopped while deciding (a stall): nobody waits for the baton
                return
            after.release()

    def _stop_workers(self) -> None:
        self._stop = True
        for w in self._workers:
            if w.go.locked():
                w.go.release()
        for w in self._workers:
            if w.thread is not None:
                w.thread.join(timeout=self._stall_timeout_s)
                if w.thread.is_alive():
                    logger.error("behaviour thread %s did not stop", w.thread.name)
        self._workers = []

    def close(self) -> None:
        """Stop and join every thread. Idempotent."""
        self._stop_workers()

    def __enter__(self) -> BehaviourRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
