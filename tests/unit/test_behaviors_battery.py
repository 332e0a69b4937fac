"""The battery state machine."""

from __future__ import annotations

import pytest

from behaviors.battery import (
    BatteryAction,
    BatteryPhase,
    BatteryPolicy,
    BatteryState,
    battery_step,
)
from behaviors.snapshot import Power

POLICY = BatteryPolicy(low_percent=30.0, resume_percent=90.0, max_charge_s=500.0)


def p(percent: float, t: float, charging: int = 0) -> Power:
    return Power(percent, 12.0, charging, t)


def test_low_battery_only_triggers_when_idle() -> None:
    s = BatteryState()
    s2, a = battery_step(POLICY, s, p(20, 1.0), 1.0, idle=False)
    assert (s2, a) == (s, BatteryAction.NONE)
    s3, a = battery_step(POLICY, s, p(20, 1.0), 1.0, idle=True)
    assert a is BatteryAction.GO_CHARGE and s3.phase is BatteryPhase.TO_CHARGER
    _, a = battery_step(POLICY, s, p(50, 1.0), 1.0, idle=True)
    assert a is BatteryAction.NONE


def test_stale_power_is_ignored() -> None:
    _, a = battery_step(POLICY, BatteryState(), p(5, 1.0), 10.0, idle=True)
    assert a is BatteryAction.NONE


def test_full_cycle_service_dock_charge_leave_service() -> None:
    s = BatteryState()
    s, a = battery_step(POLICY, s, p(20, 0.0), 0.0, idle=True)
    assert a is BatteryAction.GO_CHARGE
    s, a = battery_step(POLICY, s, p(19, 5.0), 5.0, idle=False, task_outcome="running")
    assert a is BatteryAction.NONE
    s, a = battery_step(POLICY, s, p(19, 9.0, charging=1), 9.0, idle=False, task_outcome="done")
    assert a is BatteryAction.CHARGE_STARTED and s.phase is BatteryPhase.CHARGING
    s, a = battery_step(POLICY, s, p(60, 50.0, charging=1), 50.0, idle=False)
    assert a is BatteryAction.NONE
    s, a = battery_step(POLICY, s, p(91, 90.0, charging=1), 90.0, idle=False)
    assert a is BatteryAction.CHARGE_DONE and s.phase is BatteryPhase.LEAVING
    s, a = battery_step(POLICY, s, p(91, 91.0), 91.0, idle=False, task_outcome="running")
    assert a is BatteryAction.NONE
    s, a = battery_step(POLICY, s, p(91, 93.0), 93.0, idle=False, task_outcome="done")
    assert a is BatteryAction.RETURN_TO_SERVICE and s.phase is BatteryPhase.SERVICE


def test_charging_gives_up_after_max_charge_time_and_docking_can_fail() -> None:
    s = BatteryState(BatteryPhase.CHARGING, 0.0)
    _, a = battery_step(POLICY, s, p(40, 500.0, 1), 500.0, idle=False)
    assert a is BatteryAction.CHARGE_DONE
    s = BatteryState(BatteryPhase.TO_CHARGER, 0.0)
    _, a = battery_step(POLICY, s, p(10, 3.0), 3.0, idle=False, task_outcome="failed")
    assert a is BatteryAction.DOCK_FAILED


def test_policy_is_checked() -> None:
    with pytest.raises(ValueError, match="low_percent"):
        BatteryPolicy(low_percent=95.0, resume_percent=90.0)


def test_pushed_off_the_pad_while_charging_docks_again_after_a_grace_period() -> None:
    s = BatteryState(BatteryPhase.CHARGING, 0.0)
    s, a = battery_step(POLICY, s, p(50, 10.0, charging=0), 10.0, idle=False)
    assert a is BatteryAction.NONE and s.phase is BatteryPhase.CHARGING
    assert s.off_pad_since_s == 10.0
    # charge flows again within the grace period: the off-pad clock is cleared
    s, a = battery_step(POLICY, s, p(51, 12.0, charging=1), 12.0, idle=False)
    assert a is BatteryAction.NONE and s.off_pad_since_s is None
    s, a = battery_step(POLICY, s, p(51, 13.0, charging=0), 13.0, idle=False)
    s, a = battery_step(POLICY, s, p(51, 17.9, charging=0), 17.9, idle=False)
    assert a is BatteryAction.NONE and s.phase is BatteryPhase.CHARGING
    s, a = battery_step(POLICY, s, p(51, 18.0, charging=0), 18.0, idle=False)
    assert a is BatteryAction.DOCK_FAILED and s.phase is BatteryPhase.TO_CHARGER


def test_stale_power_while_charging_does_not_start_the_off_pad_clock() -> None:
    s = BatteryState(BatteryPhase.CHARGING, 0.0)
    s, a = battery_step(POLICY, s, p(50, 1.0, charging=0), 30.0, idle=False)
    assert a is BatteryAction.NONE and s.off_pad_since_s is None
