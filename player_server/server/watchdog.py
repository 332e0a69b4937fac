"""The communication watchdog: a robot stops when the client driving it goes silent.

Like a Pioneer's firmware watchdog, but in simulated time. The client that last sent a
device a command it accepted is that device's *controller*; every message from a client
(a command, a request, a REQ DATA of a PULL client) counts as hearing from it. When a
controller has not been heard from for ``timeout_s`` simulated seconds - it froze, crashed
or disconnected - the device's ``watchdog_stop()`` runs once and the device has no
controller until the next command. ``timeout_s`` 0 turns the watchdog off.

Only devices whose driver sets ``watched`` (position2d: motion) take part.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from player_server.drivers.base import Driver

log = logging.getLogger(__name__)


class CommandWatchdog:
    def __init__(self, timeout_s: float, sim_time_s: Callable[[], float]) -> None:
        if not timeout_s >= 0.0:
            raise ValueError(f"watchdog timeout must be >= 0 s, got {timeout_s}")
        self.timeout_s = timeout_s
        self._now = sim_time_s
        #: session id -> simulated time it was last heard from
        self._heard: dict[int, float] = {}
        #: id(driver) -> (driver, controlling session id, where: the robot's name)
        self._controllers: dict[int, tuple[Driver, int, str]] = {}
        self._closed: set[int] = set()
        #: devices stopped because their controller went silent
        self.stops = 0

    def heard(self, session_id: int, now_s: float) -> None:
        if self.timeout_s > 0:
            self._heard[session_id] = now_s

    def commanded(self, session_id: int, driver: Driver, where: str = "") -> None:
        """``driver`` accepted a command from this session: it is now its controller."""
        if self.timeout_s > 0:
            self._controllers[id(driver)] = (driver, session_id, where)

    def closed(self, session_id: int) -> None:
        """The connection is gone: the devices it controls stop once it times out."""
        if any(sid == session_id for _, sid, _ in self._controllers.values()):
            self._closed.add(session_id)
        else:
            self._heard.pop(session_id, None)

    def controller(self, driver: Driver) -> int | None:
        hit = self._controllers.get(id(driver))
        return hit[1] if hit is not None else None

    def check(self) -> None:
        """Stop every device whose controller has been silent too long (call once a tick)."""
        if self.timeout_s <= 0 or not self._controllers:
            return
        now = self._now()
        for key, (driver, sid, where) in list(self._controllers.items()):
            last = self._heard.get(sid)
            if last is not None and now - last <= self.timeout_s:
                continue
            del self._controllers[key]
            self.stops += 1
            log.warning("watchdog: no word from the client driving %s of %s for %.1f "
                        "simulated s; stopped", driver.driver_name, where or "?",
                        self.timeout_s)
            try:
                driver.watchdog_stop()
            except Exception:  # contained: the device keeps its last command, logged
                log.exception("watchdog: %s could not stop", driver.driver_name)
            if sid in self._closed and not any(
                    s == sid for _, s, _ in self._controllers.values()):
                self._closed.discard(sid)
                self._heard.pop(sid, None)
