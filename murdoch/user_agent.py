"""The user agent: introduces tasks for a user and reintroduces unachievable ones.

MURDOCH answers "unachievable now" when no capable agent bids. The user agent turns that into
persistence: it resubmits after a randomized exponential backoff (the k-th wait is drawn
uniformly from [d/2, d] with d = min(cap_s, base_s * 2**(k-1))), until an agent takes the task
or the user's patience runs out, and only then reports `unachievable`. The waiting and the new
rounds are run by the auctioneer from the `RetryPlan` given here, so they stay sans-IO.
"""

from __future__ import annotations

import random
from collections.abc import Callable

from murdoch.auction.auctioneer import Auctioneer, RetryPlan
from murdoch.auction.messages import Outgoing, TaskSpec


class RandomizedBackoff:
    def __init__(self, rng: random.Random, base_s: float = 1.0, cap_s: float = 60.0) -> None:
        if base_s <= 0 or cap_s < base_s:
            raise ValueError("need 0 < base_s <= cap_s")
        self._rng = rng
        self.base_s = base_s
        self.cap_s = cap_s

    def delay_s(self, tries: int) -> float:
        """Wait before the next attempt after `tries` (>= 1) unachievable rounds."""
        ceiling = min(self.cap_s, self.base_s * 2.0 ** max(0, tries - 1))
        return self._rng.uniform(ceiling / 2.0, ceiling)


class UserAgent:
    """Submits tasks through an auctioneer with a reintroduction plan."""

    def __init__(self, auctioneer: Auctioneer, backoff: RandomizedBackoff) -> None:
        self.auctioneer = auctioneer
        self.backoff = backoff

    def submit(
        self, spec: TaskSpec, now: float, patience_s: float
    ) -> tuple[str, list[Outgoing]]:
        """Introduce `spec`; keep trying until allocated or `now + patience_s`."""
        if patience_s < 0:
            raise ValueError("patience_s must be >= 0")
        plan = RetryPlan(deadline=now + patience_s, delay_s=self.backoff.delay_s)
        return self.auctioneer.announce(spec, now, retry=plan)


class TaskTimer:
    """A cron-style source of tasks: `due(now)` yields the specs whose time has come.

    `make_spec(n)` builds the n-th task (n = 0, 1, ...); the first falls due at `start_s`, then
    one every `period_s`. The owner announces what `due` returns, e.g. through a `Node`.
    """

    def __init__(
        self, make_spec: Callable[[int], TaskSpec], period_s: float, start_s: float = 0.0
    ) -> None:
        if period_s <= 0:
            raise ValueError("period_s must be > 0")
        self._make_spec = make_spec
        self.period_s = period_s
        self._next_at = start_s
        self._count = 0

    def due(self, now: float) -> list[TaskSpec]:
        specs = []
        while now >= self._next_at:
            specs.append(self._make_spec(self._count))
            self._count += 1
            self._next_at += self.period_s
        return specs
