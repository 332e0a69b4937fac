"""Tick-ordered delivery: what a lockstep participant acts on does not depend on arrival."""

from __future__ import annotations

import itertools
import random

import pytest

from murdoch.auction.messages import AUCTION_CODEC, Bid
from murdoch.auth import TeamKey
from murdoch.tick_order import TickInbox
from murdoch.transport import EndpointCore, TickConfig


def _datagram(sender: str, seq: int, tick: int, *, instance: str = "0", epoch: str = "e1",
              subjects: frozenset[str] = frozenset({"task.x"}), key: TeamKey | None = None
              ) -> bytes:
    data = AUCTION_CODEC.encode_frame(sender, seq, subjects, Bid("x", 1, sender, float(seq)),
                                      instance, tick, epoch)
    return key.sign(data) if key is not None else data


def _core(now_tick: list[int], **kw: object) -> EndpointCore:
    ticks = TickConfig(lambda: now_tick[0], epoch="e1", **kw)  # type: ignore[arg-type]
    return EndpointCore("me", AUCTION_CODEC, lambda: now_tick[0] * 0.1, ticks=ticks)


def test_release_order_is_tick_sender_instance_seq_whatever_the_arrival_order() -> None:
    traffic = [("p2", 0, 4), ("p1", 0, 4), ("p1", 1, 5), ("p2", 1, 5), ("p1", 2, 5),
               ("p3", 0, 6)]
    orders = set()
    for perm in itertools.islice(itertools.permutations(traffic), 0, 720, 7):
        now = [6]
        core = _core(now, ordered=True, late_joiner=False)
        sub = core.subscribe({"task.x"})
        for sender, seq, tick in perm:
            assert core.receive(_datagram(sender, seq, tick)) == 0  # held, not delivered
        table = {"p1/0": 3, "p2/0": 2, "p3/0": 1}
        assert core.missing(table) == {}
        core.release(5, table)
        got = [(e.sender, e.seq, e.tick) for e in sub.drain()]
        orders.add(tuple(got))
        assert core.inbox is not None and core.inbox.held == 1  # p3's tick-6 datagram waits
    assert orders == {(("p1", 0, 4), ("p2", 0, 4), ("p1", 1, 5), ("p1", 2, 5), ("p2", 1, 5))}


def test_missing_counts_declared_datagrams_not_yet_arrived() -> None:
    now = [3]
    core = _core(now, ordered=True, late_joiner=False)
    core.receive(_datagram("p1", 0, 1))
    core.receive(_datagram("p1", 2, 2))  # 1 is still on its way
    assert core.missing({"p1/0": 3, "p2/0": 1}) == {"p1/0": 1, "p2/0": 1}
    core.receive(_datagram("p1", 1, 1))
    core.receive(_datagram("p2", 0, 2))
    assert core.missing({"p1/0": 3, "p2/0": 1}) == {}
    # a repeat is refused (and counted), never delivered twice
    assert core.receive(_datagram("p1", 1, 1)) == 0
    assert core.counters.dropped == {"replayed": 1}


def test_a_late_joiner_ignores_what_came_before_it_and_needs_everything_after() -> None:
    inbox = TickInbox(late_joiner=True)
    # first tick 10: the table holds counts through tick 9; nothing is needed yet
    inbox.start(10, {"p1/0": 5})
    assert inbox.missing({"p1/0": 5}) == {}
    # tick 11: counts through 10 are the baseline (p1 sent 2 more during tick 10)
    inbox.start(11, {"p1/0": 7})
    assert inbox.missing({"p1/0": 7}) == {}
    # tick 12: p1's datagrams 7 and 8 of tick 11 and p4's first are needed
    assert inbox.missing({"p1/0": 9, "p4/1": 1}) == {"p1/0": 2, "p4/1": 1}


def test_datagrams_from_before_joining_and_undeclared_ones_are_not_acted_on() -> None:
    class H:
        def __init__(self, sender: str, seq: int, tick: int) -> None:
            self.sender, self.instance, self.seq, self.tick = sender, "0", seq, tick

    inbox = TickInbox(late_joiner=True)
    inbox.start(10, {})
    inbox.hold(H("p1", 0, 10), b"")  # stamped at the joiner's first tick: before it joined
    inbox.hold(H("p1", 1, 11), b"")
    inbox.hold(H("p2", 0, 11), b"")  # p2 died before declaring it
    inbox.start(11, {"p1/0": 1})
    inbox.start(12, {"p1/0": 2})
    released = inbox.release(11, {"p1/0": 2})
    assert [(h.sender, h.seq) for h in released] == [("p1", 1)]
    assert (inbox.before_join, inbox.undeclared) == (1, 1)


def test_wrong_epoch_missing_tick_and_stale_ticks_are_refused_and_counted() -> None:
    now = [500]
    realtime = _core(now, stale_after_ticks=100, require_tick=True)
    sub = realtime.subscribe({"task.x"})
    assert realtime.receive(_datagram("p1", 0, 450)) == 1
    assert realtime.receive(_datagram("p1", 1, 399)) == 0  # more than 100 ticks old
    assert realtime.receive(_datagram("p1", 2, 450, epoch="other")) == 0
    assert realtime.receive(_datagram("p1", 3, -1)) == 0
    assert realtime.counters.dropped == {"stale": 1, "wrong_epoch": 1, "no_tick": 1}
    assert [e.seq for e in sub.drain()] == [0]


def test_a_recorded_signed_datagram_sent_again_to_a_restarted_receiver_is_refused() -> None:
    key = TeamKey("team-secret-1")
    award = _datagram("user", 7, 120, key=key)
    now = [125]
    first = EndpointCore("p2", AUCTION_CODEC, lambda: 12.5, key=key,
                         ticks=TickConfig(lambda: now[0], epoch="e1", stale_after_ticks=100,
                                          require_tick=True))
    first.subscribe({"task.x"})
    assert first.receive(award) == 1
    # the receiver restarts (fresh replay window); much later someone replays the datagram
    now[0] = 900
    restarted = EndpointCore("p2", AUCTION_CODEC, lambda: 90.0, key=key,
                             ticks=TickConfig(lambda: now[0], epoch="e1",
                                              stale_after_ticks=100, require_tick=True))
    restarted.subscribe({"task.x"})
    assert restarted.receive(award) == 0
    assert restarted.counters.dropped == {"stale": 1}
    # and the tick cannot be changed without breaking the tag
    forged = award.replace(b",120,", b",899,")
    assert restarted.receive(forged) == 0
    assert restarted.counters.dropped == {"stale": 1, "auth_failed": 1}


def test_random_arrival_orders_with_loss_and_repeats_release_the_same_sequence() -> None:
    rng = random.Random(7)
    traffic = [(f"p{rng.randint(1, 4)}", 0, 0) for _ in range(40)]
    seqs: dict[str, int] = {}
    numbered = []
    for sender, _, _ in traffic:
        seq = seqs.get(sender, 0)
        seqs[sender] = seq + 1
        numbered.append((sender, seq, 3 + seq // 3))
    table = {f"{s}/0": n for s, n in seqs.items()}
    expected = None
    for _ in range(30):
        order = numbered + rng.sample(numbered, 5)  # some arrive twice
        rng.shuffle(order)
        core = _core([99], ordered=True, late_joiner=False)
        sub = core.subscribe({"task.x"})
        for sender, seq, tick in order:
            core.receive(_datagram(sender, seq, tick))
        assert core.missing(table) == {}
        core.release(99, table)
        got = [(e.sender, e.seq) for e in sub.drain()]
        expected = expected or got
        assert got == expected and len(got) == len(numbered)


def test_ordered_endpoints_refuse_datagrams_without_a_tick() -> None:
    core = _core([5], ordered=True)
    assert core.receive(_datagram("p1", 0, -1)) == 0
    assert core.counters.dropped == {"no_tick": 1}
    with pytest.raises(ValueError, match="epoch"):
        EndpointCore("me", AUCTION_CODEC, lambda: 0.0,
                     ticks=TickConfig(lambda: 0, epoch="bad epoch"))


def test_a_satisfied_table_stays_satisfied_and_a_new_table_is_checked_afresh() -> None:
    now = [3]
    core = _core(now, ordered=True, late_joiner=False)
    table = {"p1/0": 1}
    assert core.missing(table) == {"p1/0": 1}
    core.receive(_datagram("p1", 0, 1))
    assert core.missing(table) == {}
    assert core.missing(table) == {}  # the same table again: nothing can be missing now
    bigger = {"p1/0": 2}
    assert core.missing(bigger) == {"p1/0": 1}
    core.receive(_datagram("p1", 1, 2))
    assert core.missing(bigger) == {}
    assert core.missing({"p1/0": 2, "p2/0": 1}) == {"p2/0": 1}


def test_settling_reads_only_while_declared_datagrams_are_missing() -> None:
    """The socket is read at the release point only when the table declares datagrams not
    yet held; what is released is the same either way."""
    now = [3]
    core = _core(now, ordered=True, late_joiner=False)
    sub = core.subscribe({"task.x"})
    queued: list[bytes] = []
    polls: list[int] = []

    def poll() -> None:
        polls.append(len(queued))
        while queued:
            core.receive(queued.pop(0))

    def settle(tick: int, table: dict[str, int]) -> int:
        now[0] = tick
        return core.settle(tick, table, poll=poll, wait=lambda s: None,
                           wait_clock=lambda: 0.0, give_up_after_s=1.0)

    assert settle(3, {}) == 0 and polls == []  # nothing declared: no read
    queued.append(_datagram("p1", 0, 3))
    assert settle(4, {"p1/0": 1}) == 1 and polls == [1]  # declared, not held: read
    assert [e.message.score for e in sub.drain()] == [0.0]
    core.receive(_datagram("p1", 1, 4))  # held already (read by the node's own step)
    queued.append(_datagram("p2", 0, 5))  # stamped later: released later either way
    assert settle(5, {"p1/0": 2}) == 1 and polls == [1]  # all held: no read
    assert settle(6, {"p1/0": 2, "p2/0": 1}) == 1 and polls == [1, 1]
    assert [e.message.score for e in sub.drain()] == [1.0, 0.0]
