"""The behaviour runner: one thread per behaviour, owner sees results and failures."""

from __future__ import annotations

import dataclasses
import os
import threading

import pytest

from behaviors.basis import Hold, Wander
from behaviors.proposal import Proposal
from behaviors.runner import BehaviourFailed, BehaviourRunner, BehaviourStalled
from behaviors.snapshot import Snapshot


@dataclasses.dataclass(frozen=True)
class Echo:
    """Proposes the tick time as speed, and records the thread it ran on."""

    name: str
    seen: list = dataclasses.field(default_factory=list, compare=False)
    max_speed_mps: float = 1e9
    max_turn_radps: float = 0.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        self.seen.append(threading.current_thread().name)
        if now < 0:
            raise ValueError("negative time")
        return Proposal(True, now, 0.0)


def test_each_behaviour_runs_once_per_tick_on_its_own_thread() -> None:
    a, b = Echo("a"), Echo("b")
    with BehaviourRunner("r") as runner:
        runner.set_behaviours([a, b])
        assert runner.thread_count == 2
        for t in range(1, 6):
            proposals = runner.tick(Snapshot(float(t)), float(t))
            assert [p.vx_mps for p in proposals] == [t, t]
        assert len(a.seen) == 5 and set(a.seen) == {"r:a"} and set(b.seen) == {"r:b"}
        runner.set_behaviours([Hold(), Wander()])
        assert runner.thread_count == 2 and runner.tick(Snapshot(1.0), 1.0)[0].active
    assert runner.thread_count == 0


def test_exceptions_reach_the_owner() -> None:
    with BehaviourRunner("r") as runner:
        runner.set_behaviours([Hold(), Echo("bad")])
        with pytest.raises(BehaviourFailed, match="negative time") as info:
            runner.tick(Snapshot(0.0), -1.0)
        assert isinstance(info.value.error, ValueError) and info.value.behaviour == "bad"
        # The runner is still usable afterwards.
        assert [p.vx_mps for p in runner.tick(Snapshot(2.0), 2.0)] == [0.0, 2.0]


@dataclasses.dataclass(frozen=True)
class Sleepy:
    gate: threading.Event
    name: str = "sleepy"
    max_speed_mps: float = 0.0
    max_turn_radps: float = 0.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        self.gate.wait(5.0)
        return Proposal(False, weight=0.0)


def test_stalled_behaviour_is_reported() -> None:
    gate = threading.Event()
    runner = BehaviourRunner("r", stall_timeout_s=0.2)
    runner.set_behaviours([Sleepy(gate)])
    with pytest.raises(BehaviourStalled, match="sleepy"):
        runner.tick(Snapshot(1.0), 1.0)
    gate.set()
    runner.close()
    assert runner.thread_count == 0


def test_no_behaviours_no_threads() -> None:
    runner = BehaviourRunner()
    runner.set_behaviours([])
    assert runner.tick(Snapshot(1.0), 1.0) == []
    runner.close()
    runner.close()


def _open_descriptors() -> int:
    return len(os.listdir("/proc/self/fd"))


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_replacing_sets_releases_their_descriptors() -> None:
    before = _open_descriptors()
    with BehaviourRunner("r") as runner:
        for t in range(20):
            runner.set_behaviours([Echo(f"a{t}"), Echo(f"b{t}"), Hold()])
            assert [p.vx_mps for p in runner.tick(Snapshot(1.0), 1.0)][:2] == [1.0, 1.0]
    assert _open_descriptors() == before


def test_a_stalled_set_is_replaced_and_the_late_thread_ends_harmlessly() -> None:
    gate = threading.Event()
    runner = BehaviourRunner("r", stall_timeout_s=0.2)
    runner.set_behaviours([Echo("first"), Sleepy(gate), Echo("last")])
    with pytest.raises(BehaviourStalled, match="sleepy"):
        runner.tick(Snapshot(1.0), 1.0)
    with pytest.raises(BehaviourStalled):
        runner.tick(Snapshot(2.0), 2.0)  # broken until replaced
    runner.set_behaviours([Echo("next")])  # the sleeper is still deciding: logged, left open
    gate.set()
    for t in range(3, 8):
        assert runner.tick(Snapshot(float(t)), float(t))[0].vx_mps == t
    runner.close()
    assert runner.thread_count == 0


@dataclasses.dataclass(frozen=True)
class Bucketed:
    """Proposes the whole second as speed; says so through its inputs key."""

    name: str
    seen: list = dataclasses.field(default_factory=list, compare=False)
    max_speed_mps: float = 1e9
    max_turn_radps: float = 0.0
    key_error: bool = False

    def inputs_key(self, snapshot: Snapshot, now: float) -> int | None:
        if self.key_error:
            raise KeyError("no key")
        return None if now < 0 else int(now)

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        self.seen.append((threading.current_thread().name, now))
        return Proposal(True, float(int(now)), 0.0)


def test_a_behaviour_whose_inputs_did_not_change_is_not_woken() -> None:
    first, middle, last = Echo("first"), Bucketed("middle"), Echo("last")
    with BehaviourRunner("r") as runner:
        runner.set_behaviours([first, middle, last])
        times = [1.0, 1.25, 1.5, 2.0, 2.5, -1.0, -1.0]
        for i, t in enumerate(times[:5]):
            proposals = runner.tick(Snapshot(t), t)
            assert [p.vx_mps for p in proposals] == [t, float(int(t)), t], i
        # woken only when the key changed, always on its own thread; the baton passed over it
        assert middle.seen == [("r:middle", 1.0), ("r:middle", 2.0)]
        assert len(first.seen) == len(last.seen) == 5
        assert set(first.seen) == {"r:first"} and set(last.seen) == {"r:last"}
        with pytest.raises(BehaviourFailed, match="negative time"):
            runner.tick(Snapshot(-1.0), -1.0)  # a None key: decided every time
        assert middle.seen[-1] == ("r:middle", -1.0)
        assert runner.tick(Snapshot(3.0), 3.0)[1].vx_mps == 3.0
        assert middle.seen[-1] == ("r:middle", 3.0)


def test_all_behaviours_unchanged_wake_no_thread_and_a_failing_key_fails() -> None:
    a, b = Bucketed("a"), Bucketed("b")
    with BehaviourRunner("r") as runner:
        runner.set_behaviours([a, b])
        for t in (5.0, 5.1, 5.2):
            assert [p.vx_mps for p in runner.tick(Snapshot(t), t)] == [5.0, 5.0]
        assert len(a.seen) == len(b.seen) == 1 and runner.ticks == 3
        runner.set_behaviours([Bucketed("c", key_error=True)])
        with pytest.raises(BehaviourFailed, match="no key"):
            runner.tick(Snapshot(1.0), 1.0)
