"""The serving loop: one thread that steps the simulation and does all socket I/O.

Keeping stepping and I/O on one thread means drivers and the core need no locks and a
seeded lockstep run repeats exactly. ``PlayerServer`` owns that thread: ``start()``
binds the ports and starts it, ``stop()`` stops and joins it and re-raises whatever it
died of.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Sequence
from typing import Protocol

from player_server.drivers.base import Driver
from player_server.server.affinity import pin_current_thread
from player_server.server.core import CoreConfig, ServerCore
from player_server.server.endpoint import Endpoint
from player_server.server.log_limit import LogLimiter
from player_server.server.tcp import TcpFrontEnd

log = logging.getLogger(__name__)


class Steppable(Protocol):
    """What the loop needs of the simulator."""

    @property
    def time_s(self) -> float: ...

    @property
    def paused(self) -> bool: ...

    def step(self, n: int = 1) -> object: ...


class PlayerServer:
    """Serves ``endpoints`` over TCP while stepping ``sim``.

    speedup: simulated seconds per wall second (0 = as fast as possible).
    quit_time_s: stop once simulation time reaches it (0 = never).
    cpus: CPUs the serving thread pins itself to when it starts (None: left as inherited).
    """

    def __init__(
        self,
        sim: Steppable,
        endpoints: Sequence[Endpoint],
        *,
        interval_s: float,
        clock: Callable[[], float],
        host: str = "127.0.0.1",
        speedup: float = 1.0,
        config: CoreConfig | None = None,
        quit_time_s: float = 0.0,
        cpus: frozenset[int] | None = None,
        on_round: Callable[[], None] | None = None,
    ) -> None:
        if interval_s <= 0:
            raise ValueError(f"interval_s must be positive, got {interval_s}")
        if speedup < 0:
            raise ValueError(f"speedup must be >= 0, got {speedup}")
        self.sim = sim
        self.endpoints = list(endpoints)
        self.interval_s = interval_s
        self.speedup = speedup
        self.quit_time_s = quit_time_s
        self.cpus = cpus
        self.on_round = on_round
        """Called on the serving thread at every tick boundary, when the simulation holds
        the state of the round about to go out and before it goes out (in lockstep: once
        every participant has asked for it). An owner's participant that is not a Player
        client (the experiment runner's own MURDOCH node) takes its tick here."""
        self._clock = clock
        self.core = ServerCore(self.endpoints, lambda: float(sim.time_s), config)
        self.tcp = TcpFrontEnd(self.core, host, clock=clock)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.finished = threading.Event()
        self.error: BaseException | None = None
        self.ticks = 0
        self._drivers: list[Driver] = []
        self._eager_step = False
        #: the last poll found no client waiting for a round (paused, at full speed)
        self._none_wanted = False
        #: pipelined lockstep: the simulation is one step ahead of the last round published
        self._ahead = False
        #: ticks stepped right after the input that completed them (lockstep)
        self._eager_steps = 0
        #: exceptions raised by drivers' before_step (each contained, counted, logged)
        self.driver_errors = 0
        self._limiter = LogLimiter(log, clock=clock)

    # -- lifecycle ----------------------------------------------------------------------------
    def start(self) -> PlayerServer:
        self.tcp.bind(self.endpoints)
        # a simulator that compiles code on first use (the sensing kernels) does it now, not
        # inside the first round a client waits for
        warm = getattr(self.sim, "warm", None)
        if callable(warm):
            warm()
        self._thread = threading.Thread(target=self._run, name="player-server", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 10.0) -> None:
        self._stop.set()
        self.tcp.wake()
        if self._thread is not None:
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                raise RuntimeError("the server thread did not stop")
            self._thread = None
        else:
            self.tcp.close()  # never started: release the wake-up sockets
        if self.error is not None:
            err, self.error = self.error, None
            raise RuntimeError("the server thread failed") from err

    def __enter__(self) -> PlayerServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def ports(self) -> dict[str, int]:
        return {ep.name: ep.port for ep in self.endpoints}

    def table(self) -> str:
        """The start-up table: robot -> port -> devices."""
        rows = [("robot", "port", "devices")]
        for ep in self.endpoints:
            rows.append((ep.name, str(ep.port), ", ".join(ep.device_names())))
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        return "\n".join(f"{a:<{w0}}  {b:>{w1}}  {d}" for a, b, d in rows)

    # -- the loop -------------------------------------------------------------------------------
    @property
    def thread_id(self) -> int | None:
        """The serving thread's native id while it runs (for affinity and /proc)."""
        return self._thread.native_id if self._thread is not None else None

    def _run(self) -> None:
        if self.cpus:
            pin_current_thread(self.cpus)
        try:
            self._loop()
        except BaseException as exc:  # seen by the owner in stop()
            log.exception("server loop failed")
            self.error = exc
        finally:
            self.tcp.close()
            self.finished.set()

    def _step_and_publish(self) -> None:
        core = self.core
        hook = self.on_round
        if core.config.pipelined and core.config.lockstep:
            if not self._ahead:
                self._step()  # the state after round 0 (which went out on first request)
            if hook is not None:
                hook()
            core.publish()  # the state stepped last time; its data was prepared since
            self._step()
            core.prepare()
            self._ahead = True
        else:
            self._step()
            if hook is not None:
                hook()
            core.publish()
        self.ticks += 1

    def request_stop(self) -> None:
        """End the serving loop after the current turn (any thread, the hook included)."""
        self._stop.set()

    def _step(self) -> None:
        if not self.sim.paused:
            for d in self._drivers:
                try:
                    d.before_step()
                except Exception as exc:  # contained to this device; the step goes on
                    self.driver_errors += 1
                    self._limiter.log("before_step", logging.ERROR, "driver %s failed before "
                                      "the step: %r", d.driver_name, exc, exc_info=True)
            self.sim.step()

    def _serve_waiting_rounds(self) -> None:
        """While paused at full speed, serve waiting rounds at once (in the same write as
        their ACK)."""
        core = self.core
        if not core.rounds_wanted():
            # nothing until the next input can change that: the loop's next pass need not
            # ask again (only output is written in between)
            self._none_wanted = True
        elif not core.config.lockstep or core.lockstep_ready(self._clock()):
            core.publish()
            self.ticks += 1

    def _after_input(self) -> None:
        """Runs after a poll's input and before its output is written.

        In lockstep at full speed, the REQ DATA that completes a tick steps the
        simulation here, so that its ACK and the new round leave in one write and the
        step does not wait for another pass of the loop.
        """
        if self.sim.paused:  # (a paused simulation takes no eager step)
            if self.speedup == 0:
                self._serve_waiting_rounds()
        elif (self._eager_step and not self._stop.is_set()
                and self.core.lockstep_ready(self._clock())):
            self._step_and_publish()
            self._eager_steps += 1

    def _loop(self) -> None:
        core, tcp, sim = self.core, self.tcp, self.sim
        lockstep = core.config.lockstep
        period = self.interval_s / self.speedup if self.speedup > 0 else 0.0
        self._drivers = [d for ep in self.endpoints for d in ep.drivers.values()]
        self._eager_step = lockstep and period == 0.0
        next_due = self._clock()
        quits = self.quit_time_s > 0
        clock = self._clock
        #: the time matters to a period or to lockstep's stall timer only
        timed = period != 0.0 or lockstep
        stopping = self._stop.is_set
        after_input = self._after_input
        while not stopping():
            if quits and self._quit_reached():
                return
            now = clock() if timed else 0.0
            due = period == 0.0 or now >= next_due
            ready = due and (core.lockstep_ready(now) if lockstep else True)
            if ready and sim.paused and (self._none_wanted or not core.rounds_wanted()):
                ready = False  # paused: publish only when a client waits for a round
            self._none_wanted = False
            if ready:
                self._step_and_publish()
                tcp.flush()
                if quits and self._quit_reached():
                    return
                if period:
                    next_due += period
                    if next_due < now - period:
                        next_due = now
                timeout = 0.0
            elif not due:
                timeout = min(next_due - now, 0.1)
            else:
                timeout = 0.05  # waiting for clients; their I/O wakes the selector
            tcp.poll(timeout, after_input)

    def _quit_reached(self) -> bool:
        if self.quit_time_s > 0 and self.sim.time_s >= self.quit_time_s - 1e-9:
            log.info("quit time %.3f s reached", self.quit_time_s)
            return True
        return False
