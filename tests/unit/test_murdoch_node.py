from __future__ import annotations

import random

import pytest

from murdoch.auction import Announce, AuctionEvent, Contract, Outcome, TaskSpec
from murdoch.memory_bus import MemoryBus
from murdoch.node import Node
from murdoch.wire import WireError


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def quick(name: str, subjects: set[str], duration_s: float = 1.0, **kw: object) -> TaskSpec:
    return TaskSpec(name, frozenset(subjects), duration_s=duration_s, bid_window_s=0.2,
                    renew_period_s=0.5, contract_timeout_s=1.5, abandon_after_s=1.5, **kw)


class Setup:
    def __init__(self) -> None:
        self.clock = FakeClock()
        self.bus = MemoryBus(self.clock, random.Random(0))
        self.events: list[AuctionEvent] = []
        self.outcomes: list[Outcome] = []
        self.user = Node(self.bus.endpoint("user"), self.clock, observer=self.events.append,
                         on_outcome=self.outcomes.append)
        self.nodes = [self.user]

    def robot(self, name: str, subjects: set[str], score: float, on_start=None) -> Node:
        node = Node(self.bus.endpoint(name), self.clock, subjects=subjects,
                    metric=lambda ann: score, on_start=on_start,
                    observer=self.events.append, on_outcome=self.outcomes.append)
        self.nodes.append(node)
        return node

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / 0.05)):
            self.clock.now = round(self.clock.now + 0.05, 6)
            for node in self.nodes:
                node.step()


def test_whole_task_life_is_observable_in_order() -> None:
    s = Setup()
    started: list[Contract] = []
    robot = s.robot("r1", {"camera", "mobile"}, 1.0, on_start=started.append)
    task_id = s.user.announce(quick("track", {"camera"}))
    s.run(1.0)
    assert started and robot.busy
    robot.progress(task_id, 0.5, "half")
    s.run(1.0)
    robot.complete(task_id, "done")
    s.run(0.2)
    kinds = [e.kind for e in s.events if e.agent == "user"]
    assert kinds[:4] == ["announce", "bid", "close", "award"]
    assert "renew" in kinds and "progress" in kinds and kinds[-1] == "outcome"
    assert [e.kind for e in s.events if e.agent == "r1"] == ["bid", "start", "completed"]
    (outcome,) = s.outcomes
    assert (outcome.status, outcome.winner, outcome.reason) == ("completed", "r1", "done")
    assert s.events[-1].to_dict()["status"] == "completed"


def test_busy_or_unsubscribed_robots_hear_no_announcements() -> None:
    s = Setup()
    robot = s.robot("r1", {"camera"}, 1.0)
    assert robot.listening == {"camera", "idle"}
    first = s.user.announce(quick("a", {"camera"}, duration_s=5.0))
    s.run(0.5)
    assert robot.busy and robot.bidder and robot.bidder.contract
    assert robot.bidder.contract.task_id == first
    assert robot.listening == {"camera", f"task.{first}"}
    s.user.announce(quick("b", {"camera"}))
    s.run(0.5)
    assert s.outcomes[-1].status == "unachievable"  # the only camera robot is busy
    robot.fail(first, "gave up")
    robot.set_subjects(())  # going to charge
    assert robot.listening == frozenset()
    s.user.announce(quick("c", {"camera"}))
    s.run(0.5)
    assert [o.status for o in s.outcomes] == ["unachievable", "failed", "unachievable"]
    robot.set_subjects({"camera"})
    s.user.announce(quick("d", {"camera"}, duration_s=0.0))
    s.run(0.5)
    assert robot.busy


def test_a_running_task_can_announce_sub_tasks() -> None:
    s = Setup()
    pushers: list[Contract] = []
    watcher_ref: list[Node] = []

    def watch(contract: Contract) -> None:
        watcher_ref[0].announce(quick("push-left", {"bumper"}, parent=contract.task_id))

    watcher_ref.append(s.robot("watcher", {"laser", "camera"}, 1.0, on_start=watch))
    s.robot("pusher", {"bumper", "camera"}, 1.0, on_start=pushers.append)
    top = s.user.announce(quick("box-pushing", {"laser", "camera"}, duration_s=10.0))
    s.run(1.0)
    (contract,) = pushers
    assert contract.name == "push-left" and contract.announce.parent == top
    s.nodes[2].complete(contract.task_id)
    s.run(0.3)
    (sub_outcome,) = [o for o in s.outcomes if o.parent == top]
    assert sub_outcome.status == "completed" and sub_outcome.winner == "pusher"


def test_an_announcement_too_big_for_a_datagram_is_refused_and_not_left_open() -> None:
    s = Setup()
    with pytest.raises(WireError, match="too_large"):
        s.user.announce(quick("huge", {"camera"}, params={"blob": "x" * 2000}))
    assert s.user.auctioneer.open_tasks() == ()


def test_metric_sees_the_announcement_and_scores_decide() -> None:
    s = Setup()
    seen: list[Announce] = []

    def metric(ann: Announce) -> float:
        seen.append(ann)
        return -abs(ann.params["x"] - 3.0)

    s.nodes.append(Node(s.bus.endpoint("near"), s.clock, subjects={"mobile"}, metric=metric))
    s.robot("far", {"mobile"}, -10.0)
    s.user.announce(quick("goto", {"mobile"}, params={"x": 2.5}, metrics=(("distance", 1.0),)))
    s.run(0.5)
    assert seen[0].metric_weights == {"distance": 1.0}
    assert [e.detail["winner"] for e in s.events if e.kind == "award"] == ["near"]


def test_cancel_revokes_the_winner_and_reports_failed() -> None:
    s = Setup()
    stopped: list[str] = []
    robot = Node(s.bus.endpoint("r1"), s.clock, subjects={"camera"}, metric=lambda a: 1.0,
                 on_stop=lambda c, why: stopped.append(why))
    s.nodes.append(robot)
    task_id = s.user.announce(quick("track", {"camera"}, duration_s=9.0))
    s.run(0.5)
    assert robot.busy
    s.user.cancel(task_id, "no longer needed")
    s.run(0.2)
    assert not robot.busy and stopped == ["revoked: no longer needed"]
    (outcome,) = s.outcomes
    assert (outcome.status, outcome.reason) == ("failed", "no longer needed")


def test_a_restarted_requester_gets_fresh_task_ids() -> None:
    s = Setup()
    started: list[Contract] = []
    robot = s.robot("r1", {"camera"}, 1.0, on_start=started.append)
    first = Node(s.bus.endpoint("boss"), s.clock, agent_id="boss",
                 on_outcome=s.outcomes.append)
    s.nodes.append(first)
    old = first.announce(quick("track", {"camera"}, duration_s=0.0))
    s.run(0.5)
    robot.complete(started[-1].task_id)
    s.run(0.2)
    first.close()
    first.transport.close()
    s.nodes.remove(first)
    again = Node(s.bus.endpoint("boss"), s.clock, agent_id="boss",
                 on_outcome=s.outcomes.append)
    s.nodes.append(again)
    new = again.announce(quick("track", {"camera"}, duration_s=0.0))
    s.run(0.5)
    robot.complete(started[-1].task_id)
    s.run(0.2)
    assert [c.task_id for c in started] == [old, new]
    assert new != old and new.startswith("boss.") and old.startswith("boss.")
    assert [o.status for o in s.outcomes] == ["completed", "completed"]
    assert not robot.busy


def test_only_a_node_with_open_auctions_asks_to_be_woken_for_replies() -> None:
    s = Setup()
    robot = s.robot("r1", {"camera"}, 1.0)
    assert not robot._sub.wake_on_replies and not s.user._sub.wake_on_replies
    task_id = s.user.announce(quick("track", {"camera"}, duration_s=0.0))
    assert s.user._sub.wake_on_replies  # the bids are coming
    s.run(0.5)
    assert robot.busy and s.user._sub.wake_on_replies  # the contract's reports too
    assert not robot._sub.wake_on_replies
    robot.complete(task_id, "done")
    s.run(0.3)
    assert [o.status for o in s.outcomes] == ["completed"]
    assert not s.user._sub.wake_on_replies


def test_a_bidder_asks_to_look_at_the_other_bids_half_way_through_the_window() -> None:
    s = Setup()
    robot = s.robot("r1", {"camera"}, 1.0)
    best = s.robot("r2", {"camera"}, 2.0)
    assert robot.bidder is not None and robot.bidder.next_wakeup() is None
    spec = TaskSpec("track", frozenset({"camera"}), duration_s=1.0, bid_window_s=0.4,
                    renew_period_s=0.5, contract_timeout_s=1.5, abandon_after_s=1.5)
    s.user.announce(spec)
    s.run(0.05)  # both bid at 0.05
    assert robot.bidder.next_wakeup() == pytest.approx(0.05 + 0.2)
    assert not robot._sub.wake_on_replies and not best._sub.wake_on_replies  # not yet
    s.run(0.25)  # 0.3: both have looked; the award comes at 0.4
    assert robot.bidder.next_wakeup() is None
    assert ("r1", "outbid") in [(e.agent, e.kind) for e in s.events]
    assert best._sub.wake_on_replies  # still in contention: the award should wake it
    assert not robot._sub.wake_on_replies  # outbid: reads the award at its next poll
    s.run(0.3)
    assert best.busy and not robot.busy and not robot._sub.wake_on_replies


def test_a_bidder_rests_from_its_bid_until_it_looks_at_the_others() -> None:
    s = Setup()
    robot = s.robot("r1", {"camera"}, 1.0)
    eager = Node(s.bus.endpoint("r3"), s.clock, subjects={"camera"}, metric=lambda a: 0.5,
                 rest_while_bidding=False)
    s.nodes.append(eager)
    assert robot._sub.wake_on_traffic and eager._sub.wake_on_traffic  # waiting for work
    spec = TaskSpec("track", frozenset({"camera"}), duration_s=1.0, bid_window_s=0.4,
                    renew_period_s=0.5, contract_timeout_s=1.5, abandon_after_s=1.5)
    s.user.announce(spec)
    assert s.user._sub.wake_on_traffic  # an auctioneer never rests: its bids are coming
    s.run(0.05)  # both bid at 0.05 and look at the other bids at 0.25
    assert not robot._sub.wake_on_traffic  # nothing wakes it until then
    assert eager._sub.wake_on_traffic
    s.run(0.2)
    assert robot.bidder is not None and robot.bidder.next_wakeup() is None
    assert robot._sub.wake_on_traffic  # looked: the award and new work wake it again
    s.run(0.3)
    assert robot.busy and robot._sub.wake_on_traffic  # a contract holder never rests
