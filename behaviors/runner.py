"""Threads for behaviours: one thread per behaviour, one owner, one tick at a time.

`BehaviourRunner` owns its worker threads. Each tick the owner publishes the snapshot and
time and wakes the first worker; each worker wakes once, runs its behaviour's pure `decide`,
posts its proposal and wakes the next; the last one wakes the owner. (Under the GIL pure
Python behaviours cannot run in parallel anyway; passing the baton along costs one thread
switch per behaviour instead of a stampede.) A turn is handed on through a pipe (see
`_Worker`). A worker's only waiting point is also its only cancellation point. An exception
in a behaviour reaches the owner as `BehaviourFailed` from the next `tick()`; a behaviour
that does not answer within `stall_timeout_s` (wall time) raises `BehaviourStalled`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import threading
from collections.abc import Sequence

from behaviors.proposal import Behaviour, Proposal
from behaviors.snapshot import Snapshot

logger = logging.getLogger(__name__)

_TOKEN = b"."


class BehaviourFailed(RuntimeError):
    def __init__(self, behaviour: str, error: BaseException) -> None:
        super().__init__(f"behaviour {behaviour!r} raised {error!r}")
        self.behaviour = behaviour
        self.error = error


class BehaviourStalled(RuntimeError):
    pass


class _Worker:
    """One behaviour's thread and its wake-up pipe.

    A turn is handed on by writing one byte to the next worker's pipe (or the owner's).
    `os.write` and `os.read` release the GIL before their system call, so the thread that
    is woken finds the GIL free: one wake-up per turn. (A `threading.Lock` hand-off wakes
    the next thread while the waker still holds the GIL; the woken thread then sleeps
    again on the GIL, which costs about twice the CPU per turn.) Nothing is allocated per
    tick.
    """

    __slots__ = ("after_fd", "behaviour", "error", "go_fd", "go_write_fd", "index", "result",
                 "stopped", "thread")

    def __init__(self, index: int, behaviour: Behaviour) -> None:
        self.index = index
        self.behaviour = behaviour
        self.go_fd, self.go_write_fd = os.pipe()
        self.after_fd = self.go_write_fd
        self.result: Proposal | None = None
        self.error: BaseException | None = None
        self.stopped = False
        self.thread: threading.Thread | None = None


class BehaviourRunner:
    """Owns one thread per behaviour of the current set; `tick()` runs them all once."""

    def __init__(self, name: str = "robot", stall_timeout_s: float = 10.0) -> None:
        self._name = name
        self._stall_timeout_s = stall_timeout_s
        self._workers: list[_Worker] = []
        self._snapshot: Snapshot | None = None
        self._now = 0.0
        self._results: list[Proposal] = []
        self._ticks = 0
        self._broken = False
        self._done_fds: tuple[int, int] | None = None
        self._done_poll: select.poll | None = None

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
        self._broken = False
        if not behaviours:
            return
        self._workers = [_Worker(i, b) for i, b in enumerate(behaviours)]
        done_read, done_write = os.pipe()
        self._done_fds = (done_read, done_write)
        self._done_poll = select.poll()
        self._done_poll.register(done_read, select.POLLIN)
        for w, nxt in zip(self._workers, self._workers[1:], strict=False):
            w.after_fd = nxt.go_write_fd
        self._workers[-1].after_fd = done_write
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
        os.write(workers[0].go_write_fd, _TOKEN)
        assert self._done_poll is not None and self._done_fds is not None
        if not self._done_poll.poll(self._stall_timeout_s * 1000.0):
            self._broken = True
            late = [w.behaviour.name for w in workers if w.result is None and w.error is None]
            raise BehaviourStalled(f"behaviours {late} did not answer in time")
        os.read(self._done_fds[0], 1)
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
        go_fd = w.go_fd
        after_fd = w.after_fd
        read, write = os.read, os.write
        while True:
            read(go_fd, 1)  # the one waiting and cancellation point
            if w.stopped:
                return
            try:
                w.result = behaviour.decide(self._snapshot, self._now)  # type: ignore[arg-type]
            except BaseException as exc:  # reported to the owner by tick()
                w.error = exc
            if w.stopped:  # stopped while deciding (a stall): nobody waits for the turn
                return
            write(after_fd, _TOKEN)

    def _stop_workers(self) -> None:
        workers, self._workers = self._workers, []
        for w in workers:
            w.stopped = True
        for w in workers:
            with contextlib.suppress(OSError):
                os.write(w.go_write_fd, _TOKEN)
        # A worker writes to the next worker's pipe (the last one to the owner's), so a
        # pipe is closed only once every thread that could still write to it has ended: a
        # late write must never reach a reused descriptor. A thread that does not stop
        # keeps its pipes and those after it open.
        all_joined = True
        for w in workers:
            if w.thread is not None:
                w.thread.join(timeout=self._stall_timeout_s)
                if w.thread.is_alive():
                    logger.error("behaviour thread %s did not stop", w.thread.name)
                    all_joined = False
            if all_joined:
                os.close(w.go_fd)
                os.close(w.go_write_fd)
        done, self._done_fds, self._done_poll = self._done_fds, None, None
        if done is not None and all_joined:
            os.close(done[0])
            os.close(done[1])

    def close(self) -> None:
        """Stop and join every thread. Idempotent."""
        self._stop_workers()

    def __enter__(self) -> BehaviourRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
