"""How long the phases of an auction last: the one place the experiments take them from.

`TaskSpec` carries these per task; the runner's tasks (`USER_TASK`) and the sub-tasks a robot
auctions for its running task (`SUB_TASK`, e.g. the box watcher's pushes, which must be
re-planned quickly) use the values here. All in the auctioneer's clock (simulation seconds in
a run).
"""

from __future__ import annotations

from dataclasses import dataclass


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



USER_TASK = AuctionTiming(bid_window_s=1.0, renew_period_s=2.0, contract_timeout_s=10.0,
                          abandon_after_s=10.0)
SUB_TASK = AuctionTiming(bid_window_s=0.5, renew_period_s=1.0, contract_timeout_s=5.0,
                         abandon_after_s=5.0)
