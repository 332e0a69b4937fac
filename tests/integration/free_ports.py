"""Ports for tests that start a server on a base port and its neighbours.

A port handed out by the kernel for ``bind(0)`` lies in the ephemeral range, where any
outgoing connection may take it (or its neighbour) a moment later. A base port for a server
that listens on a run of consecutive ports is therefore taken below that range, and every port
of the run is checked free.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

_LOWEST = 20000


def _ephemeral_low() -> int:
    try:
        text = Path("/proc/sys/net/ipv4/ip_local_port_range").read_text(encoding="ascii")
        return int(text.split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def _free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def free_port_block(count: int = 16, attempts: int = 200) -> int:
    """A base port such that it and the next ``count - 1`` ports are free on 127.0.0.1, all
    below the ephemeral range. Candidates step through the range from a start that differs per
    process, so parallel test processes rarely try the same block."""
    high = min(_ephemeral_low(), 65536) - count
    span = max(high - _LOWEST, 1)
    start = (os.getpid() * 7919) % span
    for i in range(attempts):
        base = _LOWEST + (start + i * 97 * count) % span
        if all(_free(p) for p in range(base, base + count)):
            return base
    raise RuntimeError(f"no {count} consecutive free ports below {high + count}")
