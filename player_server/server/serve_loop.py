"""Serving in the foreground until the server is finished, Ctrl-C or SIGTERM.

`player-server` and `player-server --replay` both run a started server this way: SIGTERM
ends it as Ctrl-C does, and the server is stopped whatever ended the wait.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from typing import Protocol


class Stoppable(Protocol):
    @property
    def finished(self) -> threading.Event: ...

    def stop(self) -> None: ...


def serve_until_done(server: Stoppable, on_finished: Callable[[], None] | None = None) -> int:
    """Wait until `server.finished` (then call `on_finished`) or an interrupt, stop the
    server; 0, or 1 when stopping it failed (said on stderr)."""

    def _stop(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _stop)
    code = 0
    try:
        while not server.finished.wait(0.5):
            pass
        if on_finished is not None:
            on_finished()
    except KeyboardInterrupt:
        pass
    finally:
        try:
            server.stop()
        except RuntimeError as exc:
            print(f"player-server: {exc}: {exc.__cause__}", file=sys.stderr)
            code = 1
    return code
