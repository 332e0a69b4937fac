"""The bidder: a sans-IO state machine for an agent that can execute tasks.

The embedding code supplies
- `metric(announce) -> score | None`: the agent's fitness (higher is better) or None to stay out;
- `on_start(contract)`: begin executing an awarded task;
- `on_stop(contract, reason)`: stop it because the contract was revoked or lost;
and reports back with `progress()`, `complete()` and `fail()`. The agent executes one task at a
time: it bids only while it holds no contract, and declines an award that arrives while busy.

Bids are visible to every bidder: one that sees a better bid (by the auctioneer's rule) knows it
has most likely lost (an `outbid` event) but keeps listening until the award, since the better
bid may not have reached the auctioneer. The other bids are read when the owner polls (at the
latest half a window after its own bid, see `next_wakeup`, and always before the award).
A winner that hears no renewal for the
announcement's `abandon_after_s` abandons the task. A renewal for a bid whose award got lost
counts as the award. Replies to renewals of finished tasks repeat the final report, so a lost
report is sent again.
"""

from __future__ import annotations

import logging
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from murdoch.auction.messages import (
    Announce,
    AuctionEvent,
    Award,
    Bid,
    Outgoing,
    Progress,
    Renew,
    Report,
    Revoke,
    negotiation_subject,
)
from murdoch.subjects import check_subject

log = logging.getLogger(__name__)

Metric = Callable[[Announce], float | None]
Observer = Callable[[AuctionEvent], None]


@dataclass(frozen=True)
class Contract:
    """An awarded task as its winner sees it."""

    announce: Announce
    awarded_at: float

    @property
    def task_id(self) -> str:
        return self.announce.task_id

    @property
    def attempt(self) -> int:
        return self.announce.attempt

    @property
    def name(self) -> str:
        return self.announce.name


StartCallback = Callable[[Contract], None]
StopCallback = Callable[[Contract, str], None]


@dataclass
class _Pending:
    announce: Announce
    score: float
    expires_at: float
    look_at: float | None = None
    lost: bool = False


def beats(score_a: float, bidder_a: str, score_b: float, bidder_b: str) -> bool:
    """Whether bid A wins over bid B under the auctioneer's rule (score, then smaller id)."""
    return (-score_a, bidder_a) < (-score_b, bidder_b)


class Bidder:
    def __init__(
        self,
        agent_id: str,
        metric: Metric,
        on_start: StartCallback | None = None,
        on_stop: StopCallback | None = None,
        observer: Observer | None = None,
        finished_memory: int = 64,
    ) -> None:
        self.agent_id = check_subject(agent_id)
        self._metric = metric
        self._on_start = on_start
        self._on_stop = on_stop
        self._observer = observer
        self._pending: dict[tuple[str, int], _Pending] = {}
        self._contract: Contract | None = None
        self._last_renew = 0.0
        self._fraction = 0.0
        self._note = ""
        self._finished: OrderedDict[tuple[str, int], Report] = OrderedDict()
        self._finished_memory = finished_memory
        self.enabled = True

    # -- queries
    @property
    def contract(self) -> Contract | None:
        return self._contract

    @property
    def busy(self) -> bool:
        return self._contract is not None

    @property
    def pending_bids(self) -> int:
        """Bids sent whose award has not been heard yet (nor given up on)."""
        return len(self._pending)

    @property
    def contending_bids(self) -> int:
        """Pending bids that no better bid seen so far has beaten."""
        return sum(1 for p in self._pending.values() if not p.lost)

    def next_wakeup(self) -> float | None:
        """When the owner should poll next for this bidder's sake: half-way through the window
        of each open bid, to read the other bids then rather than at the close (transports
        need not wake a bidder for each bid; see `Subscription.wake_on_replies`)."""
        times = [p.look_at for p in self._pending.values() if p.look_at is not None]
        return min(times) if times else None

    @property
    def expects_award(self) -> bool:
        """Whether some bid, looked at against the others (see `next_wakeup`), is still in
        contention: then the owner wants to be woken by replies (the award)."""
        return any(p.look_at is None and not p.lost for p in self._pending.values())

    def interest(self) -> frozenset[str]:
        """Negotiation subjects this bidder must hear."""
        subjects = {p.announce.negotiation for p in self._pending.values()}
        if self._contract is not None:
            subjects.add(self._contract.announce.negotiation)
        return frozenset(subjects)

    # -- inputs from the network
    def handle(self, message: Any, now: float) -> list[Outgoing]:
        if isinstance(message, Announce):
            return self._on_announce(message, now)
        if isinstance(message, Bid):
            self._on_other_bid(message, now)
        elif isinstance(message, Award):
            return self._on_award(message, now)
        elif isinstance(message, Renew):
            return self._on_renew(message, now)
        elif isinstance(message, Revoke):
            self._on_revoke(message, now)
        return []

    def tick(self, now: float) -> list[Outgoing]:
        out: list[Outgoing] = []
        contract = self._contract
        if contract is not None and now - self._last_renew > contract.announce.abandon_after_s:
            reason = f"no renewal for {contract.announce.abandon_after_s:g} s"
            self._stop(contract, now, reason)
            out.append(self._report(contract.announce, "abandoned", reason))
        for key, pending in list(self._pending.items()):
            if now >= pending.expires_at:
                del self._pending[key]
            elif pending.look_at is not None and now >= pending.look_at:
                pending.look_at = None
        return out

    # -- inputs from the task being executed
    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        """Record progress; it is sent in answer to the next renewal."""
        if self._contract is not None and self._contract.task_id == task_id:
            self._fraction = min(1.0, max(0.0, float(fraction)))
            self._note = note

    def complete(self, task_id: str, now: float, note: str = "") -> list[Outgoing]:
        return self._finish(task_id, now, "completed", note)

    def fail(self, task_id: str, now: float, reason: str) -> list[Outgoing]:
        return self._finish(task_id, now, "failed", reason)

    def abandon(self, task_id: str, now: float, reason: str) -> list[Outgoing]:
        """Give a task back (e.g. the battery ran low); the auctioneer reallocates it."""
        contract = self._contract
        if contract is None or contract.task_id != task_id:
            return []
        self._stop(contract, now, reason)
        return [self._report(contract.announce, "abandoned", reason)]

    # -- steps
    def _on_announce(self, announce: Announce, now: float) -> list[Outgoing]:
        key = (announce.task_id, announce.attempt)
        if not self.enabled or self._contract is not None or key in self._pending:
            return []
        if key in self._finished:
            return []
        score = self._metric(announce)
        if score is None:
            return []
        score = float(score)
        expires = now + 2.0 * announce.bid_window_s + announce.renew_period_s
        self._pending[key] = _Pending(announce, score, expires, now + 0.5 * announce.bid_window_s)
        if self._observer is not None:
            self._emit(now, "bid", announce.task_id, announce.attempt, score=score)
        bid = Bid(announce.task_id, announce.attempt, self.agent_id, score)
        return [Outgoing(frozenset({announce.negotiation}), bid)]

    def _on_other_bid(self, bid: Bid, now: float) -> None:
        pending = self._pending.get((bid.task_id, bid.attempt))
        if pending is None or pending.lost or bid.bidder == self.agent_id:
            return
        if beats(bid.score, bid.bidder, pending.score, self.agent_id):
            pending.lost = True
            if self._observer is not None:
                self._emit(now, "outbid", bid.task_id, bid.attempt, by=bid.bidder,
                           score=bid.score)

    def _on_award(self, award: Award, now: float) -> list[Outgoing]:
        key = (award.task_id, award.attempt)
        pending = self._pending.get(key)
        if award.winner != self.agent_id:
            self._pending.pop(key, None)
            return []
        contract = self._contract
        if contract is not None and (contract.task_id, contract.attempt) == key:
            return []  # a duplicate
        if key in self._finished:
            return []
        if pending is None:
            return [self._decline(award.task_id, award.attempt, now, "no open bid")]
        if contract is not None:
            return [self._decline(award.task_id, award.attempt, now, "busy")]
        self._start(pending.announce, now)
        return []

    def _on_renew(self, renew: Renew, now: float) -> list[Outgoing]:
        if renew.winner != self.agent_id:
            return []
        key = (renew.task_id, renew.attempt)
        contract = self._contract
        if contract is not None and (contract.task_id, contract.attempt) == key:
            self._last_renew = now
            progress = Progress(
                renew.task_id, renew.attempt, self.agent_id, self._fraction, self._note
            )
            return [Outgoing(frozenset({contract.announce.negotiation}), progress)]
        finished = self._finished.get(key)
        if finished is not None:
            return [Outgoing(frozenset({negotiation_subject(renew.task_id)}), finished)]
        pending = self._pending.get(key)
        if pending is not None and contract is None:
            self._start(pending.announce, now)  # the award was lost; the renewal stands for it
            progress = Progress(renew.task_id, renew.attempt, self.agent_id, 0.0, "")
            return [Outgoing(frozenset({pending.announce.negotiation}), progress)]
        reason = "busy" if contract is not None else "no open bid"
        return [self._decline(renew.task_id, renew.attempt, now, reason)]

    def _on_revoke(self, revoke: Revoke, now: float) -> None:
        contract = self._contract
        if (
            contract is not None
            and revoke.winner == self.agent_id
            and (contract.task_id, contract.attempt) == (revoke.task_id, revoke.attempt)
        ):
            self._stop(contract, now, f"revoked: {revoke.reason}")

    def _start(self, announce: Announce, now: float) -> None:
        self._pending.pop((announce.task_id, announce.attempt), None)
        contract = Contract(announce, now)
        self._contract = contract
        self._last_renew = now
        self._fraction = 0.0
        self._note = ""
        self._emit(now, "start", announce.task_id, announce.attempt, name=announce.name)
        if self._on_start is not None:
            self._on_start(contract)

    def _stop(self, contract: Contract, now: float, reason: str) -> None:
        self._contract = None
        self._remember(self._report(contract.announce, "abandoned", reason).message)
        self._emit(now, "stop", contract.task_id, contract.attempt, reason=reason)
        if self._on_stop is not None:
            self._on_stop(contract, reason)

    def _finish(self, task_id: str, now: float, status: str, reason: str) -> list[Outgoing]:
        contract = self._contract
        if contract is None or contract.task_id != task_id:
            return []
        self._contract = None
        out = self._report(contract.announce, status, reason)
        self._remember(out.message)
        self._emit(now, status, task_id, contract.attempt, reason=reason)
        return [out]

    def _decline(self, task_id: str, attempt: int, now: float, reason: str) -> Outgoing:
        self._pending.pop((task_id, attempt), None)
        self._emit(now, "decline", task_id, attempt, reason=reason)
        report = Report(task_id, attempt, self.agent_id, "declined", reason)
        return Outgoing(frozenset({negotiation_subject(task_id)}), report)

    def _report(self, announce: Announce, status: str, reason: str) -> Outgoing:
        report = Report(announce.task_id, announce.attempt, self.agent_id, status, reason)
        return Outgoing(frozenset({announce.negotiation}), report)

    def _remember(self, report: Report) -> None:
        self._finished[(report.task_id, report.attempt)] = report
        while len(self._finished) > self._finished_memory:
            self._finished.popitem(last=False)

    def _emit(self, now: float, kind: str, task_id: str, attempt: int, **detail: Any) -> None:
        if self._observer is not None:
            self._observer(AuctionEvent(now, self.agent_id, kind, task_id, attempt, detail))
