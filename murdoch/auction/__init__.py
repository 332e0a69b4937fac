"""MURDOCH auctions: messages and the sans-IO auctioneer and bidder state machines."""

from murdoch.auction.auctioneer import Auctioneer, Phase, RetryPlan, best_bid
from murdoch.auction.bidder import (
    BIDDER_COUNTERS,
    Bidder,
    Contract,
    award_due,
    beats,
    listen_until,
)
from murdoch.auction.messages import (
    AUCTION_CODEC,
    AUCTION_MESSAGES,
    Announce,
    AuctionEvent,
    Award,
    Bid,
    Outcome,
    Outgoing,
    Progress,
    Renew,
    Report,
    Revoke,
    TaskSpec,
    negotiation_subject,
)

__all__ = [
    "AUCTION_CODEC",
    "AUCTION_MESSAGES",
    "BIDDER_COUNTERS",
    "Announce",
    "AuctionEvent",
    "Auctioneer",
    "Award",
    "Bid",
    "Bidder",
    "Contract",
    "Outcome",
    "Outgoing",
    "Phase",
    "Progress",
    "Renew",
    "Report",
    "RetryPlan",
    "Revoke",
    "TaskSpec",
    "award_due",
    "beats",
    "best_bid",
    "listen_until",
    "negotiation_subject",
]
