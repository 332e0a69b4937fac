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

Late awards. A bidder listens to the negotiation of each of its bids until it hears how the
round ended: the award (to it, to another bidder or to nobody), a renewal or revocation
naming another winner, a revocation naming it, or the announcement of a later attempt of the
task. It stops waiting at `listen_until(announce, bid_at)`: when the award (or the first
renewal repairing its loss) was due, plus the time a winner waits for a renewal before it
abandons; a winner that had heard nothing by then would have given the task up anyway. Until
then an award (or a renewal standing for it) is taken however late it is if the bidder is
free, and refused with a `declined` report (reason "busy") if it runs another task; after it
(heard only while the subscription is held for another reason) it is refused with reason
"bid expired". A declined award makes the auctioneer reallocate at once, so every task still
ends with exactly one outcome. Awards heard after they were due, refusals, bids that expire
unanswered and revocations of awards never heard are counted (`counters`), logged
(rate-limited on the bidder's clock) and, for expiries, reported as an `expired` event.
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
from murdoch.execution.executor import EndReports, Execution
from murdoch.ratelog import RateLimitedLog
from murdoch.subjects import check_subject

log = logging.getLogger(__name__)

BIDDER_COUNTERS = (
    "late_awards", "declined_busy", "declined_closed", "expired_bids", "revoked_unheard"
)
"""What a bidder counts of the traffic about its own bids that is not the usual course:
- late_awards: awards (or renewals standing for them) for an open bid heard after
  `award_due`, then taken or declined;
- declined_busy: awards for an open bid refused because another task is running;
- declined_closed: awards naming this bidder for a round it no longer (or never) listened to;
- expired_bids: bids given up at `listen_until` with neither award nor close heard;
- revoked_unheard: revocations naming this bidder of an award it never heard."""


def award_due(announce: Announce, bid_at: float) -> float:
    """When the award for a bid made at `bid_at`, or the first renewal that repairs its loss,
    is due at the latest: the close one window after the announcement, one window of delay,
    one renew period."""
    return bid_at + 2.0 * announce.bid_window_s + announce.renew_period_s


def listen_until(announce: Announce, bid_at: float) -> float:
    """When a bidder that bid at `bid_at` stops waiting for the round's award or close:
    `award_due` plus the time a winner waits for a renewal before abandoning its task."""
    return award_due(announce, bid_at) + announce.abandon_after_s

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
    bid_at: float
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
        log_interval_s: float = 10.0,
    ) -> None:
        self.agent_id = check_subject(agent_id)
        self._metric = metric
        self._on_start = on_start
        self._on_stop = on_stop
        self._observer = observer
        self._pending: dict[tuple[str, int], _Pending] = {}
        self._contract: Contract | None = None
        self._execution = Execution.start(0.0, 0.0)
        self._finished: EndReports[Report] = EndReports(finished_memory)
        self._finished_memory = finished_memory
        self._closed: OrderedDict[tuple[str, int], str] = OrderedDict()
        """Rounds of our bids that ended without a contract, with how (last `finished_memory`)."""
        self.counters: dict[str, int] = dict.fromkeys(BIDDER_COUNTERS, 0)
        """See `BIDDER_COUNTERS`."""
        self._ratelog = RateLimitedLog(log, log_interval_s)
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
        if contract is not None and self._execution.tick(now) == "abandon":
            reason = self._execution.abandon_reason
            self._stop(contract, now, reason)
            out.append(self._report(contract.announce, "abandoned", reason))
        for key, pending in list(self._pending.items()):
            if now >= listen_until(pending.announce, pending.bid_at):
                self._close(key, "expired")
                waited = now - pending.bid_at
                self._count("expired_bids", now,
                            "no award for our bid on %s#%d heard in %.3g s; stopped listening",
                            key[0], key[1], waited)
                self._emit(now, "expired", key[0], key[1], waited_s=waited)
            elif pending.look_at is not None and now >= pending.look_at:
                pending.look_at = None
        return out

    # -- inputs from the task being executed
    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        """Record progress; it is sent in answer to the next renewal."""
        if self._contract is not None and self._contract.task_id == task_id:
            self._execution.progress(fraction, note)

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
        if self._pending:
            for old in [k for k in self._pending if k[0] == key[0] and k[1] < key[1]]:
                self._close(old, "reannounced")  # that round is over: its award never came
        if not self.enabled or self._contract is not None or key in self._pending:
            return []
        if key in self._finished:
            return []
        score = self._metric(announce)
        if score is None:
            return []
        score = float(score)
        self._pending[key] = _Pending(announce, score, now, now + 0.5 * announce.bid_window_s)
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
        if award.winner != self.agent_id:
            if key in self._pending:
                self._close(key, "lost" if award.winner is not None else "no winner")
            return []
        contract = self._contract
        if contract is not None and (contract.task_id, contract.attempt) == key:
            return []  # a duplicate
        if key in self._finished:
            return []
        return self._awarded(key, now, "award")

    def _awarded(self, key: tuple[str, int], now: float, how: str) -> list[Outgoing]:
        """An award naming us (or a renewal standing for a lost one) for a round in which
        we hold no contract: take it, or refuse it explicitly (see the module doc)."""
        pending = self._pending.get(key)
        task_id, attempt = key
        if pending is None:
            closed = self._closed.get(key)
            reason = "bid expired" if closed == "expired" else "no open bid"
            self._count("declined_closed", now, "%s for %s#%d names us but %s; declined",
                        how, task_id, attempt, f"our bid ended ({closed})" if closed
                        else "we never bid in that round")
            return [self._decline(task_id, attempt, now, reason)]
        contract = self._contract
        due = award_due(pending.announce, pending.bid_at)
        if now > due:
            self._count("late_awards", now, "%s for %s#%d heard %.3g s after it was due; %s",
                        how, task_id, attempt, now - due,
                        "declined (busy)" if contract is not None else "taken")
        if contract is not None:
            self._count("declined_busy", now, "%s for %s#%d declined: running %s#%d",
                        how, task_id, attempt, contract.task_id, contract.attempt)
            return [self._decline(task_id, attempt, now, "busy")]
        self._start(pending.announce, now)
        return []

    def _on_renew(self, renew: Renew, now: float) -> list[Outgoing]:
        if renew.winner != self.agent_id:
            key = (renew.task_id, renew.attempt)
            if key in self._pending:
                self._close(key, "lost")  # the award to another bidder did not reach us
            return []
        key = (renew.task_id, renew.attempt)
        contract = self._contract
        if contract is not None and (contract.task_id, contract.attempt) == key:
            ex = self._execution
            ex.renewed(now)
            progress = Progress(renew.task_id, renew.attempt, self.agent_id, ex.fraction, ex.note)
            return [Outgoing(frozenset({contract.announce.negotiation}), progress)]
        finished = self._finished.get(key)
        if finished is not None:
            return [Outgoing(frozenset({negotiation_subject(renew.task_id)}), finished)]
        pending = self._pending.get(key)
        out = self._awarded(key, now, "renewal")  # the award was lost; the renewal stands for it
        if out or pending is None:
            return out
        progress = Progress(renew.task_id, renew.attempt, self.agent_id, 0.0, "")
        return [Outgoing(frozenset({pending.announce.negotiation}), progress)]

    def _on_revoke(self, revoke: Revoke, now: float) -> None:
        key = (revoke.task_id, revoke.attempt)
        contract = self._contract
        if contract is not None and (contract.task_id, contract.attempt) == key:
            if revoke.winner == self.agent_id:
                self._stop(contract, now, f"revoked: {revoke.reason}")
            return
        if key not in self._pending:
            return
        if revoke.winner == self.agent_id:
            self._count("revoked_unheard", now,
                        "%s#%d revoked from us (%s) but its award never reached us",
                        revoke.task_id, revoke.attempt, revoke.reason)
            self._close(key, "revoked")
        else:
            self._close(key, "lost")

    def _start(self, announce: Announce, now: float) -> None:
        self._pending.pop((announce.task_id, announce.attempt), None)
        contract = Contract(announce, now)
        self._contract = contract
        self._execution = Execution.start(now, announce.abandon_after_s)
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
        if (task_id, attempt) in self._pending:
            self._close((task_id, attempt), "declined")
        self._emit(now, "decline", task_id, attempt, reason=reason)
        report = Report(task_id, attempt, self.agent_id, "declined", reason)
        return Outgoing(frozenset({negotiation_subject(task_id)}), report)

    def _report(self, announce: Announce, status: str, reason: str) -> Outgoing:
        report = Report(announce.task_id, announce.attempt, self.agent_id, status, reason)
        return Outgoing(frozenset({announce.negotiation}), report)

    def _close(self, key: tuple[str, int], how: str) -> None:
        """Stop listening to the round of one of our bids; remember how it ended."""
        del self._pending[key]
        self._closed[key] = how
        self._closed.move_to_end(key)
        while len(self._closed) > self._finished_memory:
            self._closed.popitem(last=False)

    def _count(self, counter: str, now: float, message: str, *args: Any) -> None:
        self.counters[counter] += 1
        self._ratelog.warning(counter, now, f"%s: {counter}: {message}", self.agent_id, *args)

    def _remember(self, report: Report) -> None:
        self._finished.remember((report.task_id, report.attempt), report)

    def _emit(self, now: float, kind: str, task_id: str, attempt: int, **detail: Any) -> None:
        if self._observer is not None:
            self._observer(AuctionEvent(now, self.agent_id, kind, task_id, attempt, detail))
