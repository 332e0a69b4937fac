"""The one line `player-server` prints when it cannot listen (pure, apart from the probe)."""

from __future__ import annotations

import errno
import socket
from collections.abc import Callable, Iterable


def port_in_use(host: str, port: int) -> bool:
    """True when binding `host`:`port` fails with "address in use" now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as exc:
            return exc.errno == errno.EADDRINUSE
    return False


def describe_listen_error(exc: OSError, host: str, ports: Iterable[int],
                          in_use: Callable[[str, int], bool] = port_in_use) -> str:
    """Name the port that is taken and suggest ``-p 0``; other errors as they are."""
    if exc.errno != errno.EADDRINUSE:
        return f"cannot listen on {host}: {exc.strerror or exc}"
    wanted = [p for p in ports if p]
    taken = next((p for p in wanted if in_use(host, p)), None)
    where = f"port {taken}" if taken is not None else (
        f"a port in {min(wanted)}-{max(wanted)}" if wanted else "a port")
    return (f"cannot listen on {host}: {where} is already in use (another player-server?); "
            f"give another base port with -p, or -p 0 for free ports")
