"""Battery management as a pure state machine.

In service a robot works and bids. Whenever it is idle (between tasks) it checks its charge;
below `low_percent` it leaves service: it drops all its subjects, docks at the nearest charger,
charges until `resume_percent` (or `max_charge_s` passes), backs off the pad and returns to
service. A robot that stops receiving charge before it is full (pushed off the pad, say) for
`off_pad_grace_s` docks again. The agent feeds it the latest power reading and whether it is
idle, and carries out the returned action.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from behaviors.snapshot import Power


class BatteryPhase(Enum):
    SERVICE = "service"
    TO_CHARGER = "to-charger"
    CHARGING = "charging"
    LEAVING = "leaving"


class BatteryAction(Enum):
    NONE = "none"
    GO_CHARGE = "go-charge"  # drop subjects and start docking
    CHARGE_STARTED = "charge-started"
    CHARGE_DONE = "charge-done"  # start leaving the pad
    RETURN_TO_SERVICE = "return-to-service"  # take subjects back
    DOCK_FAILED = "dock-failed"


@dataclass(frozen=True, slots=True)
class BatteryPolicy:
    low_percent: float = 25.0
    resume_percent: float = 95.0
    max_charge_s: float = math.inf
    max_age_s: float = 1.0
    off_pad_grace_s: float = 5.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.low_percent < self.resume_percent <= 100.0:
            raise ValueError(
                "battery policy: expected 0 <= low_percent < resume_percent <= 100, found "
                f"low={self.low_percent} resume={self.resume_percent}"
            )


@dataclass(frozen=True, slots=True)
class BatteryState:
    phase: BatteryPhase = BatteryPhase.SERVICE
    since_s: float = 0.0
    off_pad_since_s: float | None = None  # while charging: when charge stopped flowing


def battery_step(
    policy: BatteryPolicy,
    state: BatteryState,
    power: Power | None,
    now: float,
    *,
    idle: bool,
    task_outcome: str = "",
) -> tuple[BatteryState, BatteryAction]:
    """Advance the battery state machine by one tick.

    `task_outcome` is the outcome of the agent's internal dock/undock task this tick
    ("running", "done", "failed" or "" when none is running).
    """
    fresh = power is not None and now - power.time_s <= policy.max_age_s
    phase = state.phase
    if phase is BatteryPhase.SERVICE:
        if idle and fresh and power is not None and power.percent < policy.low_percent:
            return BatteryState(BatteryPhase.TO_CHARGER, now), BatteryAction.GO_CHARGE
        return state, BatteryAction.NONE
    if phase is BatteryPhase.TO_CHARGER:
        if fresh and power is not None and power.charging > 0:
            return BatteryState(BatteryPhase.CHARGING, now), BatteryAction.CHARGE_STARTED
        if task_outcome in ("failed", "done"):  # ended without charge flowing: try again
            return BatteryState(BatteryPhase.TO_CHARGER, now), BatteryAction.DOCK_FAILED
        return state, BatteryAction.NONE
    if phase is BatteryPhase.CHARGING:
        full = fresh and power is not None and power.percent >= policy.resume_percent
        if full or now - state.since_s >= policy.max_charge_s:
            return BatteryState(BatteryPhase.LEAVING, now), BatteryAction.CHARGE_DONE
        if fresh and power is not None and power.charging <= 0:
            off_since = state.off_pad_since_s if state.off_pad_since_s is not None else now
            if now - off_since >= policy.off_pad_grace_s:  # off the pad: dock again
                return BatteryState(BatteryPhase.TO_CHARGER, now), BatteryAction.DOCK_FAILED
            if state.off_pad_since_s is None:
                return BatteryState(phase, state.since_s, now), BatteryAction.NONE
        elif state.off_pad_since_s is not None:
            return BatteryState(phase, state.since_s), BatteryAction.NONE
        return state, BatteryAction.NONE
    # LEAVING
    if task_outcome in ("done", "failed"):
        return BatteryState(BatteryPhase.SERVICE, now), BatteryAction.RETURN_TO_SERVICE
    return state, BatteryAction.NONE
