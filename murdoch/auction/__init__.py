"""MURDOCH auctions: messages and the sans-IO auctioneer and bidder state machines."""

from murdoch.auction import messages
from murdoch.auction.auctioneer import Auctioneer, Phase, RetryPlan, best_bid
from murdoch.auction.bidder import (
    BIDDER_COUNTERS,
    Bidder,
    Contract,
    award_due,
    beats,
    listen_until,
)
from murdoch.auction.messages import *  # noqa: F403 (the names messages.__all__ declares)

__all__ = [
    "BIDDER_COUNTERS",
    "Auctioneer",
    "Bidder",
    "Contract",
    "Phase",
    "RetryPlan",
    "award_due",
    "beats",
    "best_bid",
    "listen_until",
]
__all__ += messages.__all__
