"""Auctioneer and bidder state machines, driven by hand without any transport."""

from __future__ import annotations

import random
from typing import Any

import pytest

from murdoch.auction import (
    Announce,
    Auctioneer,
    AuctionEvent,
    Award,
    Bid,
    Bidder,
    Contract,
    Outgoing,
    Phase,
    Progress,
    Renew,
    Report,
    Revoke,
    TaskSpec,
    best_bid,
)
from murdoch.user_agent import RandomizedBackoff, TaskTimer, UserAgent

SPEC = TaskSpec(
    "track",
    frozenset({"camera", "mobile"}),
    duration_s=10.0,
    bid_window_s=0.5,
    renew_period_s=1.0,
    contract_timeout_s=3.0,
    abandon_after_s=3.0,
)


def only(out: list[Outgoing], kind: type) -> Any:
    (item,) = out
    assert isinstance(item.message, kind)
    return item.message


def announce_of(auctioneer: Auctioneer, spec: TaskSpec = SPEC) -> tuple[str, Announce]:
    task_id, out = auctioneer.announce(spec, 0.0)
    (item,) = out
    assert item.subjects == {"camera", "mobile", "idle"}
    return task_id, item.message


def test_award_goes_to_the_best_score_and_ties_to_the_smallest_id() -> None:
    events: list[AuctionEvent] = []
    auctioneer = Auctioneer("user", events.append)
    task_id, _ann = announce_of(auctioneer)
    for bidder, score in (("r3", 2.0), ("r1", 5.0), ("r2", 5.0)):
        assert auctioneer.handle(Bid(task_id, 1, bidder, score), 0.1) == []
    assert auctioneer.tick(0.49) == []
    award = only(auctioneer.tick(0.5), Award)
    assert (award.winner, award.score, award.bids) == ("r1", 5.0, 3)
    assert auctioneer.winner_of(task_id) == "r1"
    assert [e.kind for e in events] == ["announce", "bid", "bid", "bid", "close", "award"]
    assert best_bid({"b": 1.0, "a": 1.0, "c": 0.5}) == ("a", 1.0)


def test_late_duplicate_and_stale_bids_are_ignored() -> None:
    auctioneer = Auctioneer("user")
    task_id, _ = announce_of(auctioneer)
    auctioneer.handle(Bid(task_id, 1, "r1", 1.0), 0.1)
    auctioneer.handle(Bid(task_id, 1, "r1", 9.0), 0.2)  # a bidder bids once
    auctioneer.handle(Bid(task_id, 0, "r2", 9.0), 0.2)  # another round
    auctioneer.handle(Bid(task_id, 1, "r3", 9.0), 0.6)  # after the window
    award = only(auctioneer.tick(0.6), Award)
    assert (award.winner, award.bids) == ("r1", 1)


def test_no_bid_makes_the_task_unachievable_with_a_reason() -> None:
    auctioneer = Auctioneer("user")
    task_id, _ = announce_of(auctioneer)
    award = only(auctioneer.tick(0.5), Award)
    assert award.winner is None and award.reason
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.task_id, outcome.status) == (task_id, "unachievable")
    assert "no capable agent" in outcome.reason
    assert auctioneer.open_tasks() == ()


def contracted(auctioneer: Auctioneer) -> str:
    task_id, _ = announce_of(auctioneer)
    auctioneer.handle(Bid(task_id, 1, "r1", 1.0), 0.1)
    auctioneer.tick(0.5)
    return task_id


def test_renewals_and_progress_keep_the_contract_until_completion() -> None:
    auctioneer = Auctioneer("user")
    task_id = contracted(auctioneer)
    now = 0.5
    for n in range(1, 6):
        now += 1.0
        renew = only(auctioneer.tick(now), Renew)
        assert (renew.winner, renew.n) == ("r1", n)
        auctioneer.handle(Progress(task_id, 1, "r1", n / 10, ""), now + 0.01)
    assert auctioneer.phase_of(task_id) is Phase.CONTRACTED
    auctioneer.handle(Report(task_id, 1, "r1", "completed", "done"), now + 0.5)
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.status, outcome.winner, outcome.attempts) == ("completed", "r1", 1)


def test_failure_is_reported_with_its_reason() -> None:
    auctioneer = Auctioneer("user")
    task_id = contracted(auctioneer)
    auctioneer.handle(Report(task_id, 1, "r1", "failed", "box stuck"), 2.0)
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.status, outcome.reason) == ("failed", "box stuck")


def test_silent_winner_is_revoked_then_the_task_is_reauctioned_after_the_guard() -> None:
    events: list[AuctionEvent] = []
    auctioneer = Auctioneer("user", events.append)
    task_id = contracted(auctioneer)
    renews = [auctioneer.tick(t) for t in (1.5, 2.5)]
    assert all(isinstance(r[0].message, Renew) for r in renews)
    assert auctioneer.tick(3.45) == []
    revoke = only(auctioneer.tick(3.51), Revoke)
    assert revoke.winner == "r1"
    assert auctioneer.tick(6.0) == []  # waiting out abandon_after_s
    again = only(auctioneer.tick(6.52), Announce)
    assert again.attempt == 2
    auctioneer.handle(Report(task_id, 1, "r1", "completed", ""), 6.6)  # stale round
    auctioneer.handle(Bid(task_id, 2, "r2", 0.5), 6.7)
    assert only(auctioneer.tick(7.1), Award).winner == "r2"
    assert "reallocation" in [e.kind for e in events]
    assert auctioneer.take_outcomes() == []


def test_declined_award_is_reauctioned_at_once() -> None:
    auctioneer = Auctioneer("user")
    task_id = contracted(auctioneer)
    auctioneer.handle(Report(task_id, 1, "r1", "declined", "busy"), 0.6)
    assert only(auctioneer.tick(0.6), Announce).attempt == 2


def test_completion_heard_while_waiting_to_reallocate_still_counts() -> None:
    auctioneer = Auctioneer("user")
    task_id = contracted(auctioneer)
    auctioneer.tick(3.6)  # revoked
    auctioneer.handle(Report(task_id, 1, "r1", "completed", "just made it"), 4.0)
    (outcome,) = auctioneer.take_outcomes()
    assert outcome.status == "completed"


def test_attempts_are_bounded_and_timeouts_fail_the_task() -> None:
    spec = TaskSpec("t", frozenset({"x"}), bid_window_s=0.1, max_attempts=2, timeout_s=5.0)
    auctioneer = Auctioneer("user")
    task_id, _ = auctioneer.announce(spec, 0.0)
    auctioneer.handle(Bid(task_id, 1, "r1", 1.0), 0.05)
    auctioneer.tick(0.1)
    auctioneer.handle(Report(task_id, 1, "r1", "declined", "busy"), 0.2)
    auctioneer.tick(0.2)
    auctioneer.handle(Bid(task_id, 2, "r2", 1.0), 0.25)
    assert only(auctioneer.tick(0.35), Award).winner == "r2"
    auctioneer.handle(Report(task_id, 2, "r2", "abandoned", "battery"), 0.4)
    auctioneer.tick(0.4)
    (outcome,) = auctioneer.take_outcomes()
    assert (outcome.status, outcome.reason) == ("failed", "gave up after 2 attempts")

    task_id, _ = auctioneer.announce(spec, 10.0)
    auctioneer.handle(Bid(task_id, 1, "r1", 1.0), 10.05)
    auctioneer.tick(10.1)
    for t in (11.0, 12.0, 13.0, 14.0, 15.0):
        auctioneer.tick(t)
        auctioneer.handle(Progress(task_id, 1, "r1", 0.1, ""), t)
    assert isinstance(auctioneer.tick(15.2)[0].message, Revoke)
    (outcome,) = auctioneer.take_outcomes()
    assert outcome.status == "failed" and "within 5 s" in outcome.reason


class Robot:
    """A bidder with recording callbacks."""

    def __init__(self, name: str, score: float | None) -> None:
        self.started: list[Contract] = []
        self.stopped: list[str] = []
        self.events: list[AuctionEvent] = []
        self.bidder = Bidder(
            name,
            lambda ann: score,
            on_start=self.started.append,
            on_stop=lambda c, why: self.stopped.append(why),
            observer=self.events.append,
        )


def test_bidder_bids_once_per_round_and_only_when_capable_and_free() -> None:
    auctioneer = Auctioneer("user")
    _, ann = announce_of(auctioneer)
    robot = Robot("r1", 2.0)
    bid = only(robot.bidder.handle(ann, 0.0), Bid)
    assert (bid.bidder, bid.score) == ("r1", 2.0)
    assert robot.bidder.handle(ann, 0.01) == []  # duplicate announcement
    assert robot.bidder.interest() == {ann.negotiation}
    assert Robot("r9", None).bidder.handle(ann, 0.0) == []  # not capable


def test_seeing_a_better_bid_means_probably_lost_but_the_award_decides() -> None:
    auctioneer = Auctioneer("user")
    _, ann = announce_of(auctioneer)
    robot = Robot("r2", 2.0)
    robot.bidder.handle(ann, 0.0)
    robot.bidder.handle(Bid(ann.task_id, 1, "r3", 1.0), 0.01)
    assert robot.bidder.contending_bids == 1
    robot.bidder.handle(Bid(ann.task_id, 1, "r1", 2.0), 0.02)  # same score, smaller id
    assert robot.bidder.contending_bids == 0 and robot.bidder.pending_bids == 1
    assert [e.kind for e in robot.events] == ["bid", "outbid"]
    # r1's bid never reached the auctioneer: r2 still listens and takes the award
    assert robot.bidder.interest() == {ann.negotiation}
    robot.bidder.handle(Award(ann.task_id, 1, "r2", 2.0, 2, ""), 0.5)
    assert robot.started and robot.bidder.pending_bids == 0


def test_winner_runs_answers_renewals_and_reports() -> None:
    auctioneer = Auctioneer("user")
    _, ann = announce_of(auctioneer)
    robot = Robot("r1", 2.0)
    robot.bidder.handle(ann, 0.0)
    robot.bidder.handle(Award(ann.task_id, 1, "r1", 2.0, 1, ""), 0.5)
    assert [c.task_id for c in robot.started] == [ann.task_id] and robot.bidder.busy
    robot.bidder.handle(Award(ann.task_id, 1, "r1", 2.0, 1, ""), 0.6)  # duplicate
    assert len(robot.started) == 1
    robot.bidder.progress(ann.task_id, 0.4, "on my way")
    progress = only(robot.bidder.handle(Renew(ann.task_id, 1, "r1", 1), 1.5), Progress)
    assert (progress.fraction, progress.note) == (0.4, "on my way")
    report = only(robot.bidder.complete(ann.task_id, 2.0, "seen"), Report)
    assert (report.status, report.reason) == ("completed", "seen")
    assert not robot.bidder.busy
    # a renewal crossing the report gets the report again
    assert only(robot.bidder.handle(Renew(ann.task_id, 1, "r1", 2), 2.5), Report) == report


def test_busy_winner_declines_and_renewal_stands_for_a_lost_award() -> None:
    auctioneer = Auctioneer("user")
    _, first = announce_of(auctioneer)
    _, second = announce_of(auctioneer)
    robot = Robot("r1", 1.0)
    robot.bidder.handle(first, 0.0)
    robot.bidder.handle(second, 0.0)
    # the first award is lost; its first renewal starts the contract
    assert isinstance(robot.bidder.handle(Renew(first.task_id, 1, "r1", 1), 1.5)[0].message,
                      Progress)
    assert robot.bidder.contract is not None
    decline = only(robot.bidder.handle(Award(second.task_id, 1, "r1", 1.0, 1, ""), 1.6), Report)
    assert (decline.status, decline.reason) == ("declined", "busy")
    stranger = only(robot.bidder.handle(Renew("other.1", 1, "r1", 1), 1.7), Report)
    assert stranger.status == "declined"


def test_winner_without_renewals_abandons_and_a_revoke_stops_it() -> None:
    auctioneer = Auctioneer("user")
    _, ann = announce_of(auctioneer)
    robot = Robot("r1", 1.0)
    robot.bidder.handle(ann, 0.0)
    robot.bidder.handle(Award(ann.task_id, 1, "r1", 1.0, 1, ""), 0.5)
    assert robot.bidder.tick(3.4) == []
    report = only(robot.bidder.tick(3.6), Report)
    assert report.status == "abandoned" and robot.stopped == ["no renewal for 3 s"]

    _, ann2 = announce_of(auctioneer)
    robot.bidder.handle(ann2, 4.0)
    robot.bidder.handle(Award(ann2.task_id, 1, "r1", 1.0, 1, ""), 4.5)
    robot.bidder.handle(Revoke(ann2.task_id, 1, "r1", "silent"), 5.0)
    assert robot.stopped[-1] == "revoked: silent" and not robot.bidder.busy


def test_award_to_someone_else_frees_the_bidder() -> None:
    auctioneer = Auctioneer("user")
    _, ann = announce_of(auctioneer)
    robot = Robot("r2", 1.0)
    robot.bidder.handle(ann, 0.0)
    assert robot.bidder.interest() == {ann.negotiation}
    robot.bidder.handle(Award(ann.task_id, 1, "r1", 3.0, 2, ""), 0.5)
    assert robot.bidder.interest() == frozenset() and not robot.started
    # pending bids also expire on their own (see the late-award tests for the bound)
    _, ann2 = announce_of(auctioneer)
    robot.bidder.handle(ann2, 1.0)
    robot.bidder.tick(1.0 + 2 * 0.5 + 1.0 + 3.0)
    assert robot.bidder.interest() == frozenset()


def test_user_agent_reintroduces_with_growing_randomized_waits_until_the_deadline() -> None:
    events: list[AuctionEvent] = []
    auctioneer = Auctioneer("user", events.append)
    backoff = RandomizedBackoff(random.Random(5), base_s=1.0, cap_s=8.0)
    agent = UserAgent(auctioneer, backoff)
    spec = TaskSpec("monitor-object", frozenset({"overhead-camera"}), bid_window_s=0.1)
    _task_id, _ = agent.submit(spec, 0.0, patience_s=20.0)
    now = 0.0
    announces = 0
    while auctioneer.open_tasks() and now < 60.0:
        now = round(now + 0.05, 2)
        announces += sum(isinstance(o.message, Announce) for o in auctioneer.tick(now))
    waits = [e.detail["delay_s"] for e in events if e.kind == "retry"]
    assert len(waits) >= 3 and announces == len(waits)
    for k, wait in enumerate(waits, start=1):
        ceiling = min(8.0, 2.0 ** (k - 1))
        assert ceiling / 2 <= wait <= ceiling
    (outcome,) = auctioneer.take_outcomes()
    assert outcome.status == "unachievable" and "retried" in outcome.reason
    assert now <= 20.0 + 8.0


def test_user_agent_stops_retrying_once_someone_bids() -> None:
    auctioneer = Auctioneer("user")
    agent = UserAgent(auctioneer, RandomizedBackoff(random.Random(1), 1.0, 4.0))
    spec = TaskSpec("cleanup", frozenset({"bumper"}), bid_window_s=0.1)
    task_id, _ = agent.submit(spec, 0.0, patience_s=30.0)
    auctioneer.tick(0.1)  # nobody
    now = 0.1
    while auctioneer.phase_of(task_id) is not Phase.BIDDING:
        now += 0.05
        auctioneer.tick(now)
    auctioneer.handle(Bid(task_id, 2, "r4", 1.0), now)
    assert only(auctioneer.tick(now + 0.1), Award).winner == "r4"


def test_task_spec_checks_its_timing() -> None:
    with pytest.raises(ValueError, match="contract_timeout_s"):
        TaskSpec("t", frozenset({"x"}), renew_period_s=2.0, contract_timeout_s=1.0)
    with pytest.raises(ValueError, match="bid_window_s"):
        TaskSpec("t", frozenset({"x"}), bid_window_s=0.0)


def test_timer_introduces_tasks_on_schedule() -> None:
    timer = TaskTimer(lambda n: TaskSpec(f"patrol-{n}", frozenset({"mobile"})), 10.0, 5.0)
    assert timer.due(4.9) == []
    assert [s.name for s in timer.due(5.0)] == ["patrol-0"]
    assert [s.name for s in timer.due(26.0)] == ["patrol-1", "patrol-2"]
    with pytest.raises(ValueError):
        TaskTimer(lambda n: TaskSpec("x", frozenset()), 0.0)
