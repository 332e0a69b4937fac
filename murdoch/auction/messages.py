"""MURDOCH auction messages (on the wire) and the task, event and outcome records (local).

Wire messages, one round of one task::

    Announce  auctioneer -> required subjects + idle     task, metrics, negotiation subject
    Bid       bidder     -> negotiation subject          score (higher wins); all bidders see it
    Award     auctioneer -> negotiation subject          the close: winner, or None with a reason
    Renew     auctioneer -> negotiation subject          contract renewal, every renew period
    Progress  winner     -> negotiation subject          answer to a renewal
    Report    winner     -> negotiation subject          completed | failed | declined | abandoned
    Revoke    auctioneer -> negotiation subject          the contract is withdrawn

Bid, Award, Progress and Report are replies (``REPLY = True``): answers within a negotiation that
only the parties expecting them need at once (the auctioneer its bids, progress and reports; a
bidder whose bid is still in contention its award). Transports with a reply lane wake the others
for them only when they poll anyway, and deliver them before what arrived on the main lane.
Every message carries `task_id` and `attempt` (one auction round of the task; a reallocation
or a reintroduction starts the next attempt), so stale traffic from an earlier round is ignored.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar, NamedTuple

from murdoch.subjects import IDLE, SubjectSet, check_subject, subject_set
from murdoch.wire import Codec
from murdoch.wire_values import freeze

REPORT_STATUSES = ("completed", "failed", "declined", "abandoned")
__all__ = [
    "AUCTION_CODEC",
    "AUCTION_MESSAGES",
    "Announce",
    "AuctionEvent",
    "Award",
    "Bid",
    "Outcome",
    "Outgoing",
    "Progress",
    "Renew",
    "Report",
    "Revoke",
    "TaskSpec",
    "negotiation_subject",
]
"""What `murdoch.auction` re-exports."""

OUTCOME_STATUSES = ("completed", "failed", "unachievable")


def _finite(name: str, value: float, minimum: float = 0.0) -> None:
    if not math.isfinite(value) or value < minimum:
        raise ValueError(f"{name} must be a finite number >= {minimum}, got {value}")


_NO_PARAMS: Mapping[str, Any] = MappingProxyType({})


def _frozen_mapping(value: Mapping[str, Any]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise TypeError(f"params must be a mapping, got {type(value).__name__}")
    if not value:
        return _NO_PARAMS
    frozen: Mapping[str, Any] = freeze(dict(value))
    return frozen


@dataclass(frozen=True)
class RoundMessage:
    """What every auction message starts with: the task and its auction round."""

    task_id: str
    attempt: int


@dataclass(frozen=True)
class ContractMessage(RoundMessage):
    """A message about the contract of a round's winner."""

    winner: str


@dataclass(frozen=True)
class Announce(RoundMessage):
    KIND: ClassVar[str] = "announce"
    name: str
    subjects: tuple[str, ...]
    params: Mapping[str, Any]
    duration_s: float
    metrics: tuple[tuple[str, float], ...]
    negotiation: str
    bid_window_s: float
    renew_period_s: float
    abandon_after_s: float
    parent: str | None

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", _frozen_mapping(self.params))
        check_subject(self.negotiation)
        times = (self.duration_s, self.bid_window_s, self.renew_period_s, self.abandon_after_s)
        if not all(0.0 <= t < math.inf for t in times):
            for name in ("duration_s", "bid_window_s", "renew_period_s", "abandon_after_s"):
                _finite(name, getattr(self, name))

    @property
    def metric_weights(self) -> dict[str, float]:
        return dict(self.metrics)


@dataclass(frozen=True)
class Bid(RoundMessage):
    KIND: ClassVar[str] = "bid"
    REPLY: ClassVar[bool] = True
    bidder: str
    score: float

    def __post_init__(self) -> None:
        if not math.isfinite(self.score):
            raise ValueError("score must be finite")


@dataclass(frozen=True)
class Award(RoundMessage):
    KIND: ClassVar[str] = "award"
    REPLY: ClassVar[bool] = True
    winner: str | None
    score: float | None
    bids: int
    reason: str


@dataclass(frozen=True)
class Renew(ContractMessage):
    KIND: ClassVar[str] = "renew"
    n: int


@dataclass(frozen=True)
class Progress(ContractMessage):
    KIND: ClassVar[str] = "progress"
    REPLY: ClassVar[bool] = True
    fraction: float
    note: str


@dataclass(frozen=True)
class Report(ContractMessage):
    KIND: ClassVar[str] = "report"
    REPLY: ClassVar[bool] = True
    status: str
    reason: str

    def __post_init__(self) -> None:
        if self.status not in REPORT_STATUSES:
            raise ValueError(f"status must be one of {REPORT_STATUSES}, got {self.status!r}")


@dataclass(frozen=True)
class Revoke(ContractMessage):
    KIND: ClassVar[str] = "revoke"
    reason: str


AUCTION_MESSAGES: tuple[type, ...] = (Announce, Bid, Award, Renew, Progress, Report, Revoke)
AUCTION_CODEC = Codec(AUCTION_MESSAGES)


class Outgoing(NamedTuple):
    """A message a state machine wants published, with its subject set."""

    subjects: SubjectSet
    message: Any


@dataclass(frozen=True)
class TaskSpec:
    """A task as its requester describes it.

    `subjects` are the resources it needs (the announcement also adds `idle`); `metrics` name
    what bidders evaluate, with weights when several are summed. Times are in the clock of the
    auctioneer's owner (simulation seconds in experiments): `bid_window_s` from announcement to
    close, `renew_period_s` between renewals, `contract_timeout_s` of silence from the winner
    before it is dropped, `abandon_after_s` of silence from the auctioneer before the winner
    gives up, `timeout_s` (optional) from award to failure, `max_attempts` rounds in all.
    """

    name: str
    subjects: SubjectSet
    params: Mapping[str, Any] = field(default_factory=dict)
    duration_s: float = 0.0
    metrics: tuple[tuple[str, float], ...] = ()
    bid_window_s: float = 0.25
    renew_period_s: float = 1.0
    contract_timeout_s: float = 3.0
    abandon_after_s: float = 3.0
    timeout_s: float | None = None
    max_attempts: int = 10
    parent: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "subjects", subject_set(self.subjects))
        object.__setattr__(self, "params", _frozen_mapping(self.params))
        object.__setattr__(self, "metrics", tuple((str(n), float(w)) for n, w in self.metrics))
        if not self.name:
            raise ValueError("a task needs a name")
        _finite("duration_s", self.duration_s)
        for name in ("bid_window_s", "renew_period_s", "contract_timeout_s", "abandon_after_s"):
            _finite(name, getattr(self, name), minimum=1e-6)
        if self.timeout_s is not None:
            _finite("timeout_s", self.timeout_s, minimum=1e-6)
        if self.max_attempts < 1:
            raise ValueError("max_attempts must be >= 1")
        if self.contract_timeout_s <= self.renew_period_s:
            raise ValueError("contract_timeout_s must exceed renew_period_s")
        if self.abandon_after_s <= self.renew_period_s:
            raise ValueError("abandon_after_s must exceed renew_period_s")

    @property
    def announce_subjects(self) -> SubjectSet:
        return self.subjects | {IDLE}


def negotiation_subject(task_id: str) -> str:
    return check_subject(f"task.{task_id}")


@dataclass(frozen=True)
class AuctionEvent:
    """Something observable happened: for logs such as a run's events.jsonl."""

    time_s: float
    agent: str
    kind: str
    task_id: str
    attempt: int
    detail: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "time_s": self.time_s,
            "agent": self.agent,
            "kind": self.kind,
            "task_id": self.task_id,
            "attempt": self.attempt,
            **{k: v for k, v in self.detail.items()},
        }


@dataclass(frozen=True)
class Outcome:
    """How a task ended; every introduced task gets exactly one."""

    task_id: str
    name: str
    status: str
    reason: str
    winner: str | None
    attempts: int
    time_s: float
    parent: str | None = None

    def __post_init__(self) -> None:
        if self.status not in OUTCOME_STATUSES:
            raise ValueError(f"status must be one of {OUTCOME_STATUSES}")
