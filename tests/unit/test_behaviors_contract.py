"""Every basis behaviour through the shared contract checker."""

from __future__ import annotations

import dataclasses
import math
import random

import pytest

from behaviors import basis
from behaviors.contract import ContractViolation, check_behaviour, random_snapshot
from behaviors.proposal import Proposal
from behaviors.snapshot import Snapshot

RED = 0xFF0000
GREEN = 0x00FF00

BEHAVIOURS = [
    basis.AvoidWithSonar(),
    basis.AvoidWithSonar(ignore_half_angle_rad=math.radians(30)),
    basis.AvoidWithLaser(),
    basis.Wander(seed=3),
    basis.Wander(seed=4, turn_bias_radps=-0.4, speed_mps=0.0),
    basis.ServoToLocation(1.0, -2.0),
    basis.VisualServoToColour(RED, aim_fraction=0.2),
    basis.VisualServoToColour(RED, stop_range_m=1.0),
    basis.KeepDistanceToColour(RED, distance_m=1.2),
    basis.PushWithBumpers(),
    basis.WatchForMotionWithLaser(),
    basis.DockAtCharger(2.0, 2.0),
    basis.BoxAlignmentFromLaser(),
    basis.GoalFromCamera(GREEN),
    basis.TurnAbout(),
    basis.BackOff(),
    basis.Hold(),
    basis.Cruise(speed_mps=0.15),
    basis.CruiseOnHeading(0.5),
    basis.ViewOfEnd(RED, aim_fraction=0.2),
    basis.ViewOfEnd(GREEN),
]


def _snapshots(seed: int, count: int = 40) -> list[Snapshot]:
    rng = random.Random(seed)
    return [
        random_snapshot(rng, 1.0 + 0.1 * i, colours=(RED, GREEN), odd=i % 3 == 0)
        for i in range(count)
    ]


@pytest.mark.parametrize("behaviour", BEHAVIOURS, ids=lambda b: b.name)
def test_behaviour_honours_contract(behaviour: basis.Wander) -> None:
    assert check_behaviour(behaviour, _snapshots(7)) >= 40


@pytest.mark.parametrize("behaviour", BEHAVIOURS, ids=lambda b: b.name)
def test_behaviour_is_frozen(behaviour: basis.Wander) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        behaviour.name = "changed"  # type: ignore[misc]


@dataclasses.dataclass
class _Counting:
    """Impure on purpose: remembers how often it was asked."""

    name: str = "counting"
    max_speed_mps: float = 1.0
    max_turn_radps: float = 1.0
    calls: int = 0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        self.calls += 1
        return Proposal(True, 0.1 * (self.calls % 2), 0.0)


@dataclasses.dataclass(frozen=True)
class _TooFast:
    name: str = "too-fast"
    max_speed_mps: float = 0.1
    max_turn_radps: float = 1.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return Proposal(True, 0.5, 0.0)


@dataclasses.dataclass(frozen=True)
class _Stale:
    """Uses odometry however old it is."""

    name: str = "stale"
    max_speed_mps: float = 1.0
    max_turn_radps: float = 1.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        if snapshot.odometry is None:
            return Proposal(False, weight=0.0)
        return Proposal(True, 0.1, 0.0)


@dataclasses.dataclass(frozen=True)
class _Fragile:
    name: str = "fragile"
    max_speed_mps: float = 1.0
    max_turn_radps: float = 1.0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        assert snapshot.laser is not None
        return Proposal(False, weight=0.0)


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        (_Counting(), "not deterministic"),
        (_TooFast(), "|vx|"),
        (_Stale(), "stale"),
        (_Fragile(), "raised"),
    ],
)
def test_checker_catches_broken_behaviours(bad: object, message: str) -> None:
    with pytest.raises(ContractViolation, match=message.replace("|", r"\|")):
        check_behaviour(bad, _snapshots(1, 5))  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class _LyingKey:
    """Its proposal follows time, but its inputs key claims it never changes."""

    name: str = "lying-key"
    max_speed_mps: float = 100.0
    max_turn_radps: float = 0.0

    def inputs_key(self, snapshot: Snapshot, now: float) -> int:
        return 0

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        return Proposal(True, min(now, 100.0), 0.0)


def test_an_inputs_key_that_hides_a_change_breaks_the_contract() -> None:
    with pytest.raises(ContractViolation, match="same inputs key"):
        check_behaviour(_LyingKey(), [Snapshot(time_s=1.0)])
