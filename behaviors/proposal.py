"""What a behaviour proposes for one tick, and the protocol every behaviour follows."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from behaviors.snapshot import Snapshot


@dataclass(frozen=True, slots=True)
class Proposal:
    """A behaviour's wish for this tick.

    `active` False means "no opinion" (the arbiter ignores it). `weight` in [0, 1] is the
    behaviour's own urgency, used by weighted-sum arbitration. `signal` names something the
    behaviour noticed (e.g. "motion", "at-goal", "docked"); tasks turn signals into stage
    changes and events. `value` is an optional number attached to the signal.
    """

    active: bool
    vx_mps: float = 0.0
    vyaw_radps: float = 0.0
    weight: float = 1.0
    signal: str = ""
    value: float = 0.0


INACTIVE = Proposal(active=False, weight=0.0)


@runtime_checkable
class Behaviour(Protocol):
    """A pure basis behaviour: the same snapshot and time always give the same proposal."""

    @property
    def name(self) -> str: ...

    @property
    def max_speed_mps(self) -> float: ...

    @property
    def max_turn_radps(self) -> float: ...

    def decide(self, snapshot: Snapshot, now: float) -> Proposal: ...


def clamp(value: float, limit: float) -> float:
    """Clamp to [-limit, limit]; NaN becomes 0."""
    if value != value:  # NaN
        return 0.0
    if value > limit:
        return limit
    if value < -limit:
        return -limit
    return value


def finite_or(value: float, default: float) -> float:
    return value if math.isfinite(value) else default
