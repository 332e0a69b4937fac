"""Which files of a folder were written to since the last look.

The runner reads the robots' JSON-lines logs every simulation tick, and a robot writes to
them a few times a run: a read of each log each tick was a dozen system calls a tick
returning nothing. On Linux, `FolderWrites` asks the kernel instead (inotify): one read a
tick tells which files were written. The kernel queues the note while the writer's `write`
runs, so a line a robot wrote before it ended its tick is known to the runner when the
runner handles that tick, as it was with the reads.

Where inotify cannot be had (another system, a limit reached), or its queue overflowed,
`written` answers None: "read them all".
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import struct
import sys
from pathlib import Path

log = logging.getLogger(__name__)

_IN_MODIFY = 0x00000002
_IN_Q_OVERFLOW = 0x00004000
_IN_IGNORED = 0x00008000  # the watch is gone (its folder removed)
_IN_NONBLOCK = os.O_NONBLOCK
_IN_CLOEXEC = getattr(os, "O_CLOEXEC", 0o2000000)
_EVENT = struct.Struct("iIII")  # wd, mask, cookie, len (then len bytes of name)
_READ_BYTES = 1 << 16
_MAX_READS = 64  # one look reads at most 4 MiB of notes; more is an overflow


def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        libc.inotify_init1  # noqa: B018 (present in every glibc and musl since 2.9)
        libc.inotify_add_watch  # noqa: B018
    except (OSError, AttributeError):
        return None
    return libc


def parse_notes(buffer: bytes) -> tuple[set[str], bool]:
    """The file names of the inotify notes in ``buffer``, and whether one of them says the
    queue overflowed (or the watch went away): notes were then lost."""
    names: set[str] = set()
    lost = False
    at = 0
    end = len(buffer)
    while at + _EVENT.size <= end:
        _wd, mask, _cookie, length = _EVENT.unpack_from(buffer, at)
        at += _EVENT.size
        if mask & (_IN_Q_OVERFLOW | _IN_IGNORED):
            lost = True
        if length:
            names.add(buffer[at:at + length].rstrip(b"\0").decode("utf-8", "replace"))
        at += length
    return names, lost


class FolderWrites:
    """The names of the files in ``folder`` written to since the last call of `written`."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self._fd: int | None = None
        self._first = True
        libc = _libc()
        if libc is None:
            return
        fd = libc.inotify_init1(_IN_NONBLOCK | _IN_CLOEXEC)
        if fd < 0:
            log.debug("inotify unavailable (%s): the logs are read every tick",
                      os.strerror(ctypes.get_errno()))
            return
        if libc.inotify_add_watch(fd, os.fsencode(self.folder), _IN_MODIFY) < 0:
            log.debug("cannot watch %s (%s): the logs are read every tick", self.folder,
                      os.strerror(ctypes.get_errno()))
            os.close(fd)
            return
        self._fd = fd

    @property
    def watching(self) -> bool:
        return self._fd is not None

    def written(self) -> set[str] | None:
        """Names written since the last call; None when that cannot be told (no watch, the
        first call, notes lost): every file may have been."""
        fd = self._fd
        if fd is None:
            return None
        chunks: list[bytes] = []
        for _ in range(_MAX_READS):
            try:
                chunk = os.read(fd, _READ_BYTES)
            except BlockingIOError:
                break
            except OSError:
                self.close()
                return None
            if not chunk:
                break
            chunks.append(chunk)
        else:
            return None  # still more: as good as lost
        first, self._first = self._first, False
        if not chunks:
            return None if first else set()
        names, lost = parse_notes(b"".join(chunks))
        return None if lost or first else names

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
