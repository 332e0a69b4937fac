"""Checks the event invariants while a soak run goes: a thread of its own follows
events.jsonl and prints the first counter-example of each invariant as soon as it shows."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import TextIO

from experiments.observe import JsonlTail
from experiments.rundir import EVENTS
from experiments.soak.invariants import EventInvariants, Limits


class SoakMonitor:
    def __init__(self, limits: Limits, *, stream: TextIO, period_s: float = 2.0) -> None:
        self.invariants = EventInvariants(limits)
        self._stream = stream
        self._period = period_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._reported = 0

    def start(self, run_dir: Path) -> None:
        tail = JsonlTail(run_dir / EVENTS)
        self._thread = threading.Thread(target=self._follow, args=(tail,),
                                        name="soak-monitor", daemon=True)
        self._thread.start()

    def _follow(self, tail: JsonlTail) -> None:
        try:
            while not self._stop.wait(self._period):
                self._read(tail)
            self._read(tail)
        finally:
            tail.close()

    def _read(self, tail: JsonlTail) -> None:
        for e in tail.read_new():
            self.invariants.apply(e)
        breaches = self.invariants.first_breaches
        for name, example in breaches[self._reported:]:
            print(f"soak: invariant {name} broken: {example}", file=self._stream, flush=True)
        self._reported = len(breaches)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(30.0)
