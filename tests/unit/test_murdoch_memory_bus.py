from __future__ import annotations

import random

import pytest

from murdoch.auction.messages import Bid, Renew
from murdoch.auth import TeamKey
from murdoch.memory_bus import MemoryBus, NetworkFaults
from murdoch.wire import Envelope


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def bid(n: int, bidder: str = "a") -> Bid:
    return Bid("t", 1, bidder, float(n))


def test_delivery_follows_subject_subsets_and_includes_the_sender() -> None:
    clock = FakeClock()
    bus = MemoryBus(clock, random.Random(0))
    a, b = bus.endpoint("a"), bus.endpoint("b")
    wide = b.subscribe({"camera", "mobile", "idle"})
    narrow = b.subscribe({"camera"})
    own = a.subscribe({"camera", "idle"})
    a.publish({"camera", "idle"}, bid(1))
    bus.deliver_due()
    assert [e.message for e in wide.drain()] == [bid(1)]
    assert narrow.drain() == []
    (envelope,) = own.drain()
    assert (envelope.sender, envelope.seq, envelope.subjects) == ("a", 0, {"camera", "idle"})


def test_callbacks_updates_and_closing() -> None:
    clock = FakeClock()
    bus = MemoryBus(clock, random.Random(0))
    a = bus.endpoint("a")
    got: list[Envelope] = []
    with a.subscribe({"x"}, callback=got.append) as sub:
        a.publish({"x"}, bid(1))
        a.poll()
        sub.update({"y"})
        a.publish({"x"}, bid(2))
        a.publish({"y"}, bid(3))
        a.poll()
    a.publish({"y"}, bid(4))
    a.poll()
    assert [e.message.score for e in got] == [1.0, 3.0]
    assert sub.closed
    with pytest.raises(RuntimeError):
        sub.update({"x"})


def test_monitor_subscription_hears_everything() -> None:
    bus = MemoryBus(FakeClock(), random.Random(0))
    a = bus.endpoint("a")
    monitor = a.subscribe(None)
    a.publish({"p", "q"}, bid(1))
    a.publish((), bid(2))
    a.poll()
    assert len(monitor.drain()) == 2
    assert monitor.subjects is None


def test_counters_per_kind_on_both_sides() -> None:
    bus = MemoryBus(FakeClock(), random.Random(0))
    a, b = bus.endpoint("a"), bus.endpoint("b")
    b.subscribe({"x"})
    size = a.publish({"x"}, bid(1))
    a.publish({"x"}, Renew("t", 1, "b", 1))
    bus.deliver_due()
    snap = b.counters.snapshot()
    assert snap["kinds"]["bid"] == {"sent_msgs": 0, "sent_bytes": 0, "recv_msgs": 1,
                                    "recv_bytes": size}
    assert a.counters.sent("bid") == 1 and a.counters.sent() == 2
    assert a.counters.dropped == {"unmatched": 2}  # a itself listens to nothing


def test_delays_release_in_time_order_and_reorder() -> None:
    clock = FakeClock()
    faults = NetworkFaults(delay_s=(0.0, 0.1))
    bus = MemoryBus(clock, random.Random(3), faults)
    a, b = bus.endpoint("a"), bus.endpoint("b")
    sub = b.subscribe({"x"})
    for n in range(30):
        a.publish({"x"}, bid(n))
    clock.now = 0.05
    b.poll()
    early = [e.message.score for e in sub.drain()]
    clock.now = 0.2
    b.poll()
    late = [e.message.score for e in sub.drain()]
    assert 0 < len(early) < 30 and len(early) + len(late) == 30
    assert early + late != sorted(early + late)  # reordered
    assert bus.pending == 30  # a's own copies wait until a polls


def run_faulty(seed: int) -> tuple[list[float], int, int]:
    clock = FakeClock()
    faults = NetworkFaults(loss=0.3, duplicate=0.2, delay_s=(0.0, 0.05), reorder=0.1,
                           reorder_hold_s=0.2)
    bus = MemoryBus(clock, random.Random(seed), faults)
    a, b = bus.endpoint("a"), bus.endpoint("b")
    sub = b.subscribe({"x"})
    for n in range(200):
        a.publish({"x"}, bid(n))
    clock.now = 1.0
    bus.deliver_due()
    return [e.message.score for e in sub.drain()], bus.datagrams_lost, bus.datagrams_duplicated


def test_faults_are_seeded_and_have_the_requested_rates() -> None:
    first = run_faulty(11)
    assert first == run_faulty(11)
    assert first != run_faulty(12)
    scores, lost, duplicated = first
    assert 90 < lost < 150  # 400 copies (a and b) at 30 %
    assert 30 < duplicated < 110
    assert len(set(scores)) < 200 < len(scores) + lost


def test_forged_datagrams_on_a_keyed_bus_are_rejected() -> None:
    bus = MemoryBus(FakeClock(), random.Random(0))
    key = TeamKey("shared-team-key")
    honest = bus.endpoint("honest", key=key)
    listener = bus.endpoint("listener", key=key)
    intruder = bus.endpoint("intruder", key=TeamKey("wrong-team-key"))
    sub = listener.subscribe({"task.t"})
    honest.publish({"task.t"}, bid(1, "honest"))
    intruder.publish({"task.t"}, bid(100, "intruder"))
    bus.deliver_due()
    assert [e.message.bidder for e in sub.drain()] == ["honest"]
    assert listener.counters.dropped == {"auth_failed": 1}


def test_bad_fault_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="loss"):
        NetworkFaults(loss=1.5)
    with pytest.raises(ValueError, match="delay_s"):
        NetworkFaults(delay_s=(0.2, 0.1))


def test_closed_endpoint_stops_receiving_and_publishing() -> None:
    bus = MemoryBus(FakeClock(), random.Random(0))
    a, b = bus.endpoint("a"), bus.endpoint("b")
    sub = b.subscribe({"x"})
    b.close()
    a.publish({"x"}, bid(1))
    bus.deliver_due()
    assert sub.drain() == []
    with pytest.raises(RuntimeError):
        b.publish({"x"}, bid(2))
    with pytest.raises(ValueError):
        bus.endpoint("a")


def test_with_hundreds_of_subscriptions_each_message_reaches_exactly_its_holders() -> None:
    # through the whole receive pipeline (header match, its cache, monitors, updates, closes)
    clock = FakeClock()
    rng = random.Random(19)
    bus = MemoryBus(clock, rng)
    sender, receiver = bus.endpoint("s"), bus.endpoint("r")
    vocabulary = ["camera", "laser", "sonar", "mobile", "gripper", "idle", "ptz"]
    holds: dict[int, frozenset[str]] = {}
    got: dict[int, list[float]] = {}
    expected: dict[int, list[float]] = {}
    subs = {}
    for n in range(300):
        holds[n] = frozenset({*rng.sample(vocabulary, rng.randint(1, 4)), f"task.{n % 60}"})
        got[n], expected[n] = [], []
        subs[n] = receiver.subscribe(
            holds[n], callback=lambda e, n=n: got[n].append(e.message.score))
    monitor = receiver.subscribe(None)
    for i in range(200):
        if i == 100:  # half-way, some subscriptions change and some close
            for n in range(0, 300, 5):
                holds[n] = frozenset(rng.sample(vocabulary, 2))
                subs[n].update(holds[n])
            for n in range(1, 300, 9):
                subs[n].close()
                del holds[n]
        subjects = frozenset(rng.sample([*vocabulary, *(f"task.{k}" for k in range(60))],
                                        rng.randint(1, 2)))
        for n, held in holds.items():
            if subjects <= held:
                expected[n].append(float(i))
        sender.publish(subjects, bid(i, "s"))
        bus.deliver_due()
    assert got == expected
    assert sum(len(v) for v in expected.values()) > 200  # the case is not vacuous
    assert len(monitor.drain()) == 200
