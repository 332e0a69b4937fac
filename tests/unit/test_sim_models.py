"""Pure models of the simulator: battery, drive helpers, wanderer, pacer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from player_server.sim.battery import Battery
from player_server.sim.drive import integrate, ramp, to_robot_frame, wrap_angle
from player_server.sim.pacing import Pacer
from player_server.sim.wander import Wanderer
from worlds import PowerSpec


def test_battery_drains_charges_goes_flat_and_recovers() -> None:
    spec = PowerSpec(capacity_j=1000.0, initial_fraction=0.5, idle_w=10.0, moving_w=20.0,
                     sensor_w=5.0, flat_fraction=0.0, resume_fraction=0.1)
    b = Battery.full_as_specified(spec)
    assert b.joules == 500.0 and not b.flat
    assert b.draw_w(0.0) == 15.0 and b.draw_w(1.0) == 35.0 and b.draw_w(3.0) == 35.0
    b.update(10.0, 35.0, 0.0)
    r = b.reading()
    assert r.joules == pytest.approx(150.0) and r.watts == 35.0 and not r.charging
    assert r.percent == pytest.approx(15.0)
    assert r.volts == pytest.approx(10.5 + 2.5 * 0.15)
    b.update(10.0, 35.0, 0.0)
    assert b.joules == 0.0 and b.flat
    b.update(0.5, 15.0, 100.0 + 15.0)  # charging at 100 W net
    assert b.charging and b.joules == pytest.approx(50.0) and b.flat  # below resume (10%)
    b.update(1.0, 15.0, 115.0)
    assert not b.flat
    for _ in range(20):
        b.update(1.0, 15.0, 115.0)
    assert b.joules == 1000.0 and b.reading().percent == 100.0


def test_drive_helpers() -> None:
    assert ramp(0.0, 1.0, 0.25) == 0.25 and ramp(0.0, -1.0, 0.25) == -0.25
    assert ramp(0.9, 1.0, 0.25) == 1.0
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    fwd, left, turn = to_robot_frame(1.0, 1.0, math.pi / 2, 1.0, 2.0, math.pi)
    assert (fwd, left, turn) == pytest.approx((1.0, 0.0, math.pi / 2))
    assert integrate(0.0, 0.0, math.pi / 2, 1.0, 0.5, 0.1) == pytest.approx(
        (-0.5, 1.0, math.pi / 2 + 0.1))


def test_wanderer_turns_away_from_obstacles() -> None:
    w = Wanderer(np.random.default_rng(0))
    bearings = np.radians([90, 45, 0, -45, -90])
    v, turn = w.decide(bearings, np.array([5.0, 5.0, 0.3, 0.4, 0.4]))
    assert v == 0.0 and turn > 0  # blocked ahead, more room on the left
    v, turn = w.decide(bearings, np.array([5.0, 5.0, 5.0, 5.0, 5.0]))
    assert v > 0.3
    v, turn = w.decide(bearings, np.array([0.8, 5.0, 5.0, 5.0, 5.0]))
    assert turn < 0  # wall close on the left: veer right


def test_pacer_sleeps_until_due() -> None:
    now = [100.0]
    slept: list[float] = []

    def sleep(s: float) -> None:
        slept.append(s)
        now[0] += s

    p = Pacer(0.1, 2.0, lambda: now[0], sleep)
    assert p.wait(1) == pytest.approx(0.05)
    now[0] += 1.0  # running late: no sleep
    assert p.wait(2) == 0.0
    fast = Pacer(0.1, 0.0, lambda: now[0], sleep)
    assert fast.wait(1000) == 0.0
    with pytest.raises(ValueError):
        Pacer(0.1, -1.0, lambda: 0.0, sleep)
