"""A robot cut off at once, as a killed process would be, while its host process goes on.

A robot running as a thread among others (`behaviors.host`) cannot be killed with a signal.
`Cut` stands in for one: the robot's body registers what it holds open (its Player
connection, its team transport) and writes its logs through `Cut.gate`; `cut()` then makes
every later write a no-op and aborts what is held (sockets shut down and closed, nothing
flushed, no goodbye), so from that moment the server and the team see what they see of a
killed process. The robot's thread notices on its next receive or send and ends.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Callable
from typing import IO, cast

from player_server.client import PlayerClient


class Cut:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._cut = False
        self._aborts: list[Callable[[], None]] = []

    @property
    def is_cut(self) -> bool:
        return self._cut

    def hold(self, abort: Callable[[], None]) -> None:
        """Call `abort` when the robot is cut (at once if it already is)."""
        with self._lock:
            if not self._cut:
                self._aborts.append(abort)
                return
        _quietly(abort)

    def gate(self, stream: IO[str]) -> IO[str]:
        """`stream` as the robot writes it: each write goes out whole and flushed, or not at
        all once the robot is cut."""
        return cast(IO[str], _GatedText(stream, self))

    def cut(self) -> None:
        """Stop every later write and abort everything held (idempotent)."""
        with self._lock:
            if self._cut:
                return
            self._cut = True
            aborts, self._aborts = self._aborts, []
        for abort in aborts:
            _quietly(abort)

    def write(self, stream: IO[str], text: str) -> None:
        with self._lock:
            if not self._cut:
                stream.write(text)
                stream.flush()


def _quietly(abort: Callable[[], None]) -> None:
    with contextlib.suppress(OSError, RuntimeError, ValueError):
        abort()


class _GatedText:
    """The writing side of a text stream behind a `Cut`."""

    def __init__(self, stream: IO[str], cut: Cut) -> None:
        self._stream = stream
        self._cut = cut

    def write(self, text: str) -> int:
        self._cut.write(self._stream, text)
        return len(text)

    def flush(self) -> None:
        """Every write is flushed as it is made."""

    def close(self) -> None:
        self._stream.close()


class AbortableClient(PlayerClient):
    """A Player connection that can also be dropped at once from another thread."""

    _aborted = False

    def abort(self) -> None:
        """Drop the connection as a process that died would: commands not yet sent are
        dropped, and the socket is shut down (a receive waiting on it in the robot's thread
        ends) and closed. An abort while the socket is still being connected drops it as
        soon as it is (`_opened`)."""
        self._aborted = True
        self._pending.clear()
        sock, self._sock = self._sock, None
        if sock is not None:
            _drop(sock)

    def _opened(self, sock: socket.socket) -> None:
        # abort() sets the flag before it looks for the socket, and the socket is held
        # before this looks at the flag: one of the two drops it, or both
        if self._aborted:
            _drop(sock)


def _drop(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):
        sock.shutdown(socket.SHUT_RDWR)
    with contextlib.suppress(OSError):
        sock.close()
