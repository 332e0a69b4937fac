"""How long the phases of an auction last: the one place the experiments take them from.

`TaskSpec` carries these per task; the runner's tasks (`USER_TASK`) and the sub-tasks a robot
auctions for its running task (`SUB_TASK`, e.g. the box watcher's pushes, which must be
re-planned quickly) use the values here. All in the auctioneer's clock (simulation seconds in
a run).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from murdoch.auction.messages import TaskSpec


@dataclass(frozen=True)
class AuctionTiming:
    bid_window_s: float
    """Announce to close: how long bids are collected."""
    renew_period_s: float
    """How often the auctioneer renews a contract (the winner answers with progress)."""
    contract_timeout_s: float
    """A winner silent this long is dropped and the task re-auctioned."""
    abandon_after_s: float
    """A winner that hears no renewal this long gives the task up."""

    def task(self, name: str, subjects: Iterable[str], params: Mapping[str, Any], *,
             duration_s: float, timeout_s: float | None, parent: str | None = None) -> TaskSpec:
        """A task announced with these timings."""
        return TaskSpec(name, frozenset(subjects), params, duration_s=duration_s,
                        bid_window_s=self.bid_window_s, renew_period_s=self.renew_period_s,
                        contract_timeout_s=self.contract_timeout_s,
                        abandon_after_s=self.abandon_after_s, timeout_s=timeout_s,
                        parent=parent)


USER_TASK = AuctionTiming(bid_window_s=1.0, renew_period_s=2.0, contract_timeout_s=10.0,
                          abandon_after_s=10.0)
SUB_TASK = AuctionTiming(bid_window_s=0.5, renew_period_s=1.0, contract_timeout_s=5.0,
                         abandon_after_s=5.0)
