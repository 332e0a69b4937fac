"""Threads for behaviours: one thread per behaviour, one owner, one tick at a time.

`BehaviourRunner` owns its worker threads. Each tick the owner publishes the snapshot and
time and wakes the first worker; each worker wakes once, runs its behaviour's pure `decide`,
posts its proposal and wakes the next; the last one wakes the owner. (Under the GIL pure
Python behaviours cannot run in parallel anyway; passing the baton along costs one thread
switch per behaviour instead of a stampede.) A turn is handed on through an eventfd (see
`_Worker`). A worker's only waiting point is also its only cancellation point. An exception
in a behaviour reaches the owner as `BehaviourFailed` from the next `tick()`; a behaviour
that does not answer within `stall_timeout_s` (wall time) raises `BehaviourStalled`.

A behaviour may also say when its inputs did not change: an optional pure
`inputs_key(snapshot, now)` returns a value such that equal keys on two ticks mean equal
proposals (`None`: decide anyway). The owner asks for the key (a few operations, no
deciding) and a worker whose key equals its previous one is not woken: its previous
proposal stands (`Wander`, for instance, changes its turn only every `period_s`). The
baton then passes over it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import struct
import sys
import threading
from collections.abc import Callable, Hashable, Sequence

from behaviors.proposal import Behaviour, Proposal
from behaviors.snapshot import Snapshot

logger = logging.getLogger(__name__)

#: one turn: an eventfd takes an 8-byte count; a pipe (where there is no eventfd) the same
_TOKEN = (1).to_bytes(8, sys.byteorder)


def _wake_channel() -> tuple[int, int]:
    """(read end, write end) of a one-thread wake-up channel.

    An eventfd (one descriptor for both ends; lighter to signal than a pipe) where the
    system has one, else a pipe.
    """
    eventfd = getattr(os, "eventfd", None)
    if eventfd is not None:
        fd: int = eventfd(0, os.EFD_CLOEXEC)
        return fd, fd
    return os.pipe()


class BehaviourFailed(RuntimeError):
    def __init__(self, behaviour: str, error: BaseException) -> None:
        super().__init__(f"behaviour {behaviour!r} raised {error!r}")
        self.behaviour = behaviour
        self.error = error


class BehaviourStalled(RuntimeError):
    pass


class _Worker:
    """One behaviour's thread and its wake-up channel (an eventfd, or a pipe).

    A turn is handed on by writing a token to the next woken worker's channel (or the
    owner's socket). `os.write` and `os.read` release the GIL before their system call,
    so the thread that is woken finds the GIL free: one wake-up per turn. (A
    `threading.Lock` hand-off wakes the next thread while the waker still holds the GIL;
    the woken thread then sleeps again on the GIL, which costs about twice the CPU per
    turn.) Nothing is allocated per tick.
    """

    __slots__ = ("after_fd", "behaviour", "error", "go_fd", "go_write_fd", "index", "key",
                 "key_of", "last", "result", "stopped", "thread")

    def __init__(self, index: int, behaviour: Behaviour) -> None:
        self.index = index
        self.behaviour = behaviour
        self.go_fd, self.go_write_fd = _wake_channel()
        self.after_fd = self.go_write_fd  # set by the owner before each turn
        self.result: Proposal | None = None
        self.error: BaseException | None = None
        self.stopped = False
        self.thread: threading.Thread | None = None
        key_of = getattr(behaviour, "inputs_key", None)
        self.key_of: Callable[[Snapshot, float], Hashable] | None = (
            key_of if callable(key_of) else None)
        self.key: Hashable = None  # inputs key of `last` (None: none yet)
        self.last: Proposal | None = None  # the proposal of the latest turn


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
        self._done: tuple[socket.socket, socket.socket] | None = None
        self._woken: list[_Worker] = []

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
        # The owner waits for the last worker on a socket whose receive timeout is the
        # stall timeout: one system call per wait.
        done_read, done_write = socket.socketpair()
        seconds = max(self._stall_timeout_s, 1e-3)
        done_read.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, struct.pack(
            "ll", int(seconds), int((seconds - int(seconds)) * 1e6)))
        self._done = (done_read, done_write)
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
        assert self._done is not None
        done_read, done_write = self._done
        self._snapshot = snapshot
        self._now = now
        results = self._results
        woken = self._woken
        woken.clear()
        for w in workers:
            key_of = w.key_of
            if key_of is not None:
                try:
                    key = key_of(snapshot, now)
                except Exception as exc:
                    raise BehaviourFailed(w.behaviour.name, exc) from exc
                if key is not None and key == w.key and w.last is not None:
                    results[w.index] = w.last
                    continue
                w.key = key
            if woken:
                woken[-1].after_fd = w.go_write_fd
            woken.append(w)
        if not woken:
            self._ticks += 1
            return results
        woken[-1].after_fd = done_write.fileno()
        os.write(woken[0].go_write_fd, _TOKEN)
        try:
            done_read.recv(64)
        except (BlockingIOError, TimeoutError):
            self._broken = True
            late = [w.behaviour.name for w in woken if w.result is None and w.error is None]
            raise BehaviourStalled(f"behaviours {late} did not answer in time") from None
        self._ticks += 1
        failed: _Worker | None = None
        for w in woken:
            if w.error is not None and failed is None:
                failed = w
            results[w.index] = w.last = w.result  # type: ignore[assignment]
            w.result = None
        if failed is not None:
            error = failed.error
            for w in woken:
                w.error = None
                w.last = None
            raise BehaviourFailed(failed.behaviour.name, error) from error  # type: ignore[arg-type]
        return results

    def _work(self, w: _Worker) -> None:
        behaviour = w.behaviour
        go_fd = w.go_fd
        read, write = os.read, os.write
        while True:
            read(go_fd, 8)  # the one waiting and cancellation point
            if w.stopped:
                return
            try:
                w.result = behaviour.decide(self._snapshot, self._now)  # type: ignore[arg-type]
            except BaseException as exc:  # reported to the owner by tick()
                w.error = exc
            if w.stopped:  # stopped while deciding (a stall): nobody waits for the turn
                return
            write(w.after_fd, _TOKEN)

    def _stop_workers(self) -> None:
        workers, self._workers = self._workers, []
        for w in workers:
            w.stopped = True
        for w in workers:
            with contextlib.suppress(OSError):
                os.write(w.go_write_fd, _TOKEN)
        # A worker writes only to a later worker's channel or the owner's socket, so a
        # channel is closed only once every thread that could still write to it has ended:
        # a late write must never reach a reused descriptor. A thread that does not stop
        # keeps its channel and those after it open.
        all_joined = True
        for w in workers:
            if w.thread is not None:
                w.thread.join(timeout=self._stall_timeout_s)
                if w.thread.is_alive():
                    logger.error("behaviour thread %s did not stop", w.thread.name)
                    all_joined = False
            if all_joined:
                os.close(w.go_fd)
                if w.go_write_fd != w.go_fd:
                    os.close(w.go_write_fd)
        done, self._done = self._done, None
        if done is not None and all_joined:
            done[0].close()
            done[1].close()

    def close(self) -> None:
        """Stop and join every thread. Idempotent."""
        self._stop_workers()

    def __enter__(self) -> BehaviourRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
