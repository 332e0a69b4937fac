"""Late awards: a bidder listens to each of its rounds until it hears how the round ended,
bounded in its own (here: a fake) clock, and counts what it cannot act on."""

from __future__ import annotations

import logging
import random
from typing import Any

import pytest

from murdoch.auction import (
    BIDDER_COUNTERS,
    Announce,
    Auctioneer,
    AuctionEvent,
    Award,
    Bid,
    Bidder,
    Contract,
    Outgoing,
    Progress,
    Renew,
    Report,
    Revoke,
    TaskSpec,
    award_due,
    listen_until,
)
from murdoch.memory_bus import MemoryBus
from murdoch.node import Node
from murdoch.ratelog import RateLimitedLog

SPEC = TaskSpec("track", frozenset({"camera"}), duration_s=10.0, bid_window_s=0.5,
                renew_period_s=1.0, contract_timeout_s=3.0, abandon_after_s=3.0)
# bid at 0: the award (or the renewal repairing its loss) is due by 2.0; listening ends at 5.0
DUE = 2.0
BOUND = 5.0


def only(out: list[Outgoing], kind: type) -> Any:
    (item,) = out
    assert isinstance(item.message, kind)
    return item.message


class Robot:
    def __init__(self, name: str = "r1", score: float = 1.0) -> None:
        self.started: list[Contract] = []
        self.events: list[AuctionEvent] = []
        self.bidder = Bidder(name, lambda ann: score, on_start=self.started.append,
                             observer=self.events.append)

    def kinds(self) -> list[str]:
        return [e.kind for e in self.events]


def announce(auctioneer: Auctioneer, now: float = 0.0, spec: TaskSpec = SPEC) -> Announce:
    _, out = auctioneer.announce(spec, now)
    return only(out, Announce)


def test_the_bounds_follow_from_the_announcement() -> None:
    ann = announce(Auctioneer("user"))
    assert award_due(ann, 0.0) == DUE
    assert listen_until(ann, 0.0) == BOUND
    assert listen_until(ann, 7.0) == 7.0 + BOUND


def test_an_award_after_the_old_expiry_is_taken_and_counted_late() -> None:
    auctioneer = Auctioneer("user")
    ann = announce(auctioneer)
    robot = Robot()
    auctioneer.handle(only(robot.bidder.handle(ann, 0.0), Bid), 0.0)
    # the auctioneer is slow: nothing from it until well after the award was due
    for t in (0.5, 1.0, 2.0, 3.0, 4.0):
        assert robot.bidder.tick(t) == []
        assert robot.bidder.interest() == {ann.negotiation}
    award = only(auctioneer.tick(4.5), Award)
    assert robot.bidder.handle(award, 4.5) == []
    assert [c.task_id for c in robot.started] == [ann.task_id] and robot.bidder.busy
    assert robot.bidder.counters["late_awards"] == 1
    # the contract then runs as usual: renewals answered, the report ends the task
    renew = only(auctioneer.tick(5.5), Renew)
    auctioneer.handle(only(robot.bidder.handle(renew, 5.5), Progress), 5.5)
    auctioneer.handle(only(robot.bidder.complete(ann.task_id, 6.0), Report), 6.0)
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.status, outcome.winner, outcome.attempts) == ("completed", "r1", 1)
    assert robot.kinds() == ["bid", "start", "completed"]


def test_a_late_renewal_stands_for_a_lost_late_award() -> None:
    ann = announce(Auctioneer("user"))
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    robot.bidder.tick(4.0)
    progress = only(robot.bidder.handle(Renew(ann.task_id, 1, "r1", 1), 4.8), Progress)
    assert progress.winner == "r1" and robot.bidder.busy
    assert robot.bidder.counters["late_awards"] == 1


def test_an_award_in_time_is_not_late() -> None:
    ann = announce(Auctioneer("user"))
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    robot.bidder.handle(Award(ann.task_id, 1, "r1", 1.0, 1, ""), DUE)
    assert robot.bidder.busy and robot.bidder.counters == dict.fromkeys(BIDDER_COUNTERS, 0)


@pytest.mark.parametrize("ending", [
    Award("user.1", 1, "r0", 2.0, 2, ""),
    Award("user.1", 1, None, None, 0, "no capable agent bid"),
    Renew("user.1", 1, "r0", 1),
    Revoke("user.1", 1, "r0", "silent"),
])
def test_hearing_how_the_round_ended_ends_listening(ending: Any) -> None:
    ann = announce(Auctioneer("user"))
    assert ann.task_id == "user.1"
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    assert robot.bidder.handle(ending, 3.0) == []
    assert robot.bidder.interest() == frozenset() and robot.bidder.pending_bids == 0
    robot.bidder.tick(BOUND + 1.0)
    assert not robot.started and robot.kinds() == ["bid"]
    assert robot.bidder.counters == dict.fromkeys(BIDDER_COUNTERS, 0)


def test_a_later_attempt_of_the_task_ends_listening_to_the_earlier_one() -> None:
    ann = announce(Auctioneer("user"))
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    again = Announce(**{**ann.__dict__, "attempt": 2})
    bid = only(robot.bidder.handle(again, 3.0), Bid)
    assert bid.attempt == 2 and robot.bidder.pending_bids == 1
    # an award of the first attempt now names a round we stopped listening to
    decline = only(robot.bidder.handle(Award(ann.task_id, 1, "r1", 1.0, 1, ""), 3.1), Report)
    assert (decline.attempt, decline.status, decline.reason) == (1, "declined", "no open bid")
    assert robot.bidder.counters["declined_closed"] == 1 and not robot.started


def test_without_any_award_listening_ends_at_the_bound(caplog: pytest.LogCaptureFixture) -> None:
    ann = announce(Auctioneer("user"))
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    with caplog.at_level(logging.WARNING, logger="murdoch.auction.bidder"):
        robot.bidder.tick(BOUND - 0.01)
        assert robot.bidder.interest() == {ann.negotiation}
        robot.bidder.tick(BOUND)
    assert robot.bidder.interest() == frozenset() and robot.bidder.pending_bids == 0
    assert robot.bidder.counters["expired_bids"] == 1
    assert robot.kinds() == ["bid", "expired"]
    assert robot.events[-1].detail == {"waited_s": BOUND}
    (line,) = [r.getMessage() for r in caplog.records]
    assert "expired_bids" in line and ann.task_id in line
    # an award that still comes (heard only if subscribed for another reason) is refused
    decline = only(robot.bidder.handle(Award(ann.task_id, 1, "r1", 1.0, 1, ""), 6.0), Report)
    assert (decline.status, decline.reason) == ("declined", "bid expired")
    assert robot.bidder.counters["declined_closed"] == 1 and not robot.started


def test_a_late_award_while_busy_is_declined_and_the_task_is_reallocated_at_once() -> None:
    auctioneer = Auctioneer("user")
    first = announce(Auctioneer("other"))
    ann = announce(auctioneer)
    robot = Robot()
    robot.bidder.handle(first, 0.0)
    auctioneer.handle(only(robot.bidder.handle(ann, 0.0), Bid), 0.0)
    robot.bidder.handle(Award(first.task_id, 1, "r1", 1.0, 1, ""), 0.5)
    assert robot.bidder.contract is not None
    assert robot.bidder.interest() == {first.negotiation, ann.negotiation}
    award = only(auctioneer.tick(4.0), Award)  # late, and we are running `first`
    decline = only(robot.bidder.handle(award, 4.0), Report)
    assert (decline.task_id, decline.status, decline.reason) == (ann.task_id, "declined", "busy")
    assert robot.bidder.counters["late_awards"] == 1
    assert robot.bidder.counters["declined_busy"] == 1
    assert robot.bidder.contract.task_id == first.task_id
    assert robot.bidder.interest() == {first.negotiation}
    # the auctioneer replaces the decliner at once; the task has one outcome in the end
    auctioneer.handle(decline, 4.0)
    again = only(auctioneer.tick(4.0), Announce)
    assert again.attempt == 2
    other = Robot("r2")
    auctioneer.handle(only(other.bidder.handle(again, 4.0), Bid), 4.0)
    award = only(auctioneer.tick(4.5), Award)
    assert award.winner == "r2"
    other.bidder.handle(award, 4.5)
    auctioneer.handle(only(other.bidder.complete(ann.task_id, 5.0), Report), 5.0)
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.status, outcome.winner, outcome.attempts) == ("completed", "r2", 2)


def test_a_revocation_of_an_award_never_heard_is_counted() -> None:
    ann = announce(Auctioneer("user"))
    robot = Robot()
    robot.bidder.handle(ann, 0.0)
    robot.bidder.handle(Revoke(ann.task_id, 1, "r1", "winner r1 silent for 3 s"), 4.0)
    assert robot.bidder.counters["revoked_unheard"] == 1
    assert robot.bidder.interest() == frozenset() and not robot.started


def test_warnings_are_rate_limited_on_the_callers_clock(caplog: pytest.LogCaptureFixture) -> None:
    ratelog = RateLimitedLog(logging.getLogger("test.ratelog"), interval_s=10.0)
    with caplog.at_level(logging.WARNING, logger="test.ratelog"):
        written = [ratelog.warning("a", t, "a at %s", t) for t in (0.0, 1.0, 9.9, 10.0)]
        written.append(ratelog.warning("b", 10.5, "b"))
    assert written == [True, False, False, True, True]
    assert [r.getMessage() for r in caplog.records] == [
        "a at 0.0", "a at 10.0 (2 more since the last such line)", "b"]
    with pytest.raises(ValueError):
        RateLimitedLog(logging.getLogger("x"), interval_s=0.0)


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_a_slow_requester_node_still_gets_its_task_done() -> None:
    """The requester's node is stepped only long after the award was due (as when its owner's
    loop lags behind simulated time): the bidder still hears the award and the renewals."""
    clock = FakeClock()
    bus = MemoryBus(clock, random.Random(0))
    started: list[Contract] = []
    outcomes = []
    user = Node(bus.endpoint("user"), clock, on_outcome=outcomes.append)
    robot = Node(bus.endpoint("r1"), clock, subjects={"camera"}, metric=lambda ann: 1.0,
                 on_start=started.append)
    spec = TaskSpec("track", frozenset({"camera"}), bid_window_s=1.0, renew_period_s=2.0,
                    contract_timeout_s=10.0, abandon_after_s=10.0)
    task_id = user.announce(spec)
    for n in range(120):  # 6 s; the user node hears the bid, then sleeps past the close
        clock.now = round(clock.now + 0.05, 6)
        robot.step()
        if n == 2:
            user.step()
    assert not started and robot.bidder is not None and robot.bidder.pending_bids == 1
    for _ in range(2):  # one late step: it closes the round; the robot takes the award
        clock.now = round(clock.now + 0.05, 6)
        user.step()
        robot.step()
    assert [c.task_id for c in started] == [task_id]
    for _ in range(100):
        clock.now = round(clock.now + 0.05, 6)
        user.step()
        robot.step()
    assert user.auctioneer.winner_of(task_id) == "r1"  # renewals answered: never silent
    robot.complete(task_id, "done")
    for _ in range(4):
        clock.now = round(clock.now + 0.05, 6)
        user.step()
        robot.step()
    assert [(o.status, o.winner, o.attempts) for o in outcomes] == [("completed", "r1", 1)]
    assert robot.bid_counters["late_awards"] == 1
    assert robot.bid_counters["expired_bids"] == 0
    assert user.bid_counters == {}
