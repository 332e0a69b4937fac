"""Limits against hostile clients, as pure logic: the out queue's bytes and compaction, the
rate-limited log, the watchdog, the per-turn input budget, the laser's SET_CONFIG window."""

from __future__ import annotations

import logging
import math
from types import SimpleNamespace
from typing import Any

import pytest
from sibling import load_sibling

from player_server.drivers.base import Driver
from player_server.drivers.ranging import scan_request
from player_server.drivers.scan_config import reported, scan_config, whole_scan
from player_server.protocol import sensor_msgs as sm
from player_server.server.__main__ import default_speedup
from player_server.server.log_limit import LogLimiter
from player_server.server.out_queue import OutQueue
from player_server.server.watchdog import CommandWatchdog

core_tests = load_sibling(__file__, "test_server_core.py")


def test_replaced_data_lets_go_of_its_bytes_and_the_queue_compacts() -> None:
    q = OutQueue(limit=1024)
    big = b"x" * 100_000
    for _ in range(10_000):
        q.push_data((40, 0, 1, 1), big, replace=True)
    assert len(q) == 1 and q.nbytes == len(big)
    assert q.entries_held <= 2 * 64 + 2
    assert q.replaced == 9_999
    assert q.take() == big and q.nbytes == 0 and len(q) == 0


def test_dropped_data_lets_go_of_its_bytes() -> None:
    q = OutQueue(limit=4)
    for i in range(1000):
        q.push_data((6, 0, 1, i), b"y" * 10, replace=False)
    q.push_reply(b"ack")
    assert len(q) == 5 and q.nbytes == 4 * 10 + 3 and q.dropped == 996
    assert q.entries_held <= 2 * 64 + 6
    q.clear_data()
    assert q.nbytes == 3 and q.take() == b"ack"


def test_log_limiter_keeps_a_burst_per_period_and_reports_what_it_held_back(
        caplog: pytest.LogCaptureFixture) -> None:
    now = [0.0]
    lim = LogLimiter(logging.getLogger("limit-test"), burst=3, period_s=10.0,
                     clock=lambda: now[0])
    caplog.set_level(logging.INFO, logger="limit-test")
    logged = [lim.log("k", logging.INFO, "line %d", i) for i in range(100)]
    assert logged.count(True) == 3 and lim.suppressed == 97
    assert lim.log("other", logging.INFO, "another key has its own burst")
    now[0] = 10.5
    assert lim.log("k", logging.INFO, "next period")
    msgs = [r.getMessage() for r in caplog.records]
    assert len(msgs) == 6 and "97 more 'k' lines were suppressed" in msgs[4]


class _Wheels(Driver):
    watched = True

    def __init__(self) -> None:
        super().__init__(0, "wheels")
        self.stops = 0

    def watchdog_stop(self) -> None:
        self.stops += 1


def test_watchdog_stops_a_device_whose_controller_went_silent() -> None:
    now = [0.0]
    wd = CommandWatchdog(2.0, lambda: now[0])
    wheels = _Wheels()
    wd.heard(1, 0.0)
    wd.commanded(1, wheels)
    for t in range(1, 40):  # heard every simulated second: never stopped
        now[0] = float(t)
        wd.heard(1, now[0])
        wd.check()
    assert wheels.stops == 0 and wd.controller(wheels) == 1
    now[0] = 40.9
    wd.check()
    assert wheels.stops == 0
    now[0] = 41.1
    wd.check()
    wd.check()
    assert wheels.stops == 1 and wd.controller(wheels) is None and wd.stops == 1


def test_watchdog_of_a_closed_connection_and_off_at_zero() -> None:
    now = [0.0]
    wd = CommandWatchdog(2.0, lambda: now[0])
    wheels = _Wheels()
    wd.heard(7, 0.0)
    wd.commanded(7, wheels)
    wd.closed(7)
    now[0] = 3.0
    wd.check()
    assert wheels.stops == 1 and not wd._heard and not wd._closed
    off = CommandWatchdog(0.0, lambda: now[0])
    off.heard(1, 0.0)
    off.commanded(1, wheels)
    now[0] = 1e6
    off.check()
    assert wheels.stops == 1
    with pytest.raises(ValueError):
        CommandWatchdog(math.nan, lambda: 0.0)


def test_input_budget_leaves_a_flood_for_later_turns() -> None:
    core, _world, eps = core_tests.make_core(input_budget=10)
    s = core_tests.connect(core, eps[0], pull=False)
    flood = core_tests.req(1, 0, 2) * 35  # DEVLIST
    core.receive(s, flood)
    assert s.counters.messages_in == 10 and core.has_backlog(s)
    assert s.counters.budget_exhausted == 1
    assert not core.accepting_input(s)  # not read again until worked through
    core.process(s)
    core.process(s)
    core.process(s)
    assert s.counters.messages_in == 35 and not core.has_backlog(s)
    assert core.accepting_input(s)


def test_output_limit_closes_the_client() -> None:
    core, _world, eps = core_tests.make_core(output_limit_bytes=2000)
    s = core_tests.connect(core, eps[0], pull=False)
    core.receive(s, core_tests.req(1, 0, 2) * 200)  # replies never taken
    for _ in range(30):
        core.process(s)
    assert s.closing is not None and "output buffer limit" in s.closing
    assert core.counters.closed_output_limit == 1 and s.queue.nbytes == 0


def _laser_spec() -> Any:
    return SimpleNamespace(min_angle_rad=-math.pi / 2, max_angle_rad=math.pi / 2,
                           resolution_rad=math.pi / 180, samples=181, max_range_m=8.0,
                           range_res_m=0.01, frequency_hz=10.0)


def _window(s: Any, cfg: sm.LaserConfig) -> Any:
    return scan_config(s, scan_request(cfg), whole_scan(s), 0.1)


def test_laser_config_accepts_a_subset_and_refuses_what_the_laser_cannot_do() -> None:
    s = _laser_spec()
    res = s.resolution_rad
    w = _window(s, sm.LaserConfig(-math.pi / 4, math.pi / 4, 3 * res, 5.0, 0.01, 0, 10.0))
    assert (w.first, w.last, w.step, w.max_range_m) == (45, 135, 3, 5.0)
    # SICK units: 100 hundredths of a degree, 10 mm, intensities on, 5 Hz (every 2nd step)
    w = _window(s, sm.LaserConfig(-math.pi / 2, math.pi / 2, 100.0, 0.0, 10.0, 1, 5.0))
    assert (w.step, w.resolution_unit, w.range_res_m, w.intensity, w.period_steps) == (
        1, "centideg", 0.01, True, 2)
    bad = [
        sm.LaserConfig(-math.pi / 2, math.pi / 2, res / 2, 8.0, 0.01, 0, 10.0),  # finer
        sm.LaserConfig(-math.pi, math.pi / 2, res, 8.0, 0.01, 0, 10.0),  # wider
        sm.LaserConfig(-math.pi / 2, math.pi / 2, res, 9.0, 0.01, 0, 10.0),  # further
        sm.LaserConfig(-math.pi / 2, math.pi / 2, res, 8.0, 0.0001, 0, 10.0),  # range res
        sm.LaserConfig(-math.pi / 2, math.pi / 2, res, 8.0, 0.01, 0, 75.0),  # rate
        sm.LaserConfig(-math.pi / 2, math.pi / 2, 25.0, 8.0, 0.01, 0, 10.0),  # 0.25 over 180
        sm.LaserConfig(-math.pi / 2, math.pi / 2 - res, 2 * res, 8.0, 0.01, 0, 10.0),
        sm.LaserConfig(math.nan, math.pi / 2, res, 8.0, 0.01, 0, 10.0),
        sm.LaserConfig(0.1, -0.1, res, 8.0, 0.01, 0, 10.0),
    ]
    for cfg in bad:
        with pytest.raises(ValueError):
            _window(s, cfg)


def test_laser_config_off_the_world_readings_is_a_fan_of_its_own() -> None:
    s = _laser_spec()  # 181 readings, one a degree
    w = _window(s, sm.LaserConfig(math.radians(-30.1), math.radians(20.0), 25.0, 0.0, 0.0, 0,
                                  0.0))
    assert w.fan == pytest.approx((math.radians(-30.1), math.radians(0.25), 201))
    assert (w.first, w.last, w.step, w.resolution_unit) == (0, 200, 1, "centideg")
    lo, hi, res, *_ = reported(s, w, 0.1)
    assert (lo, hi, res) == pytest.approx((math.radians(-30.1), math.radians(19.9), 25.0))
    # on the world's readings: a window of them, as before (no fan)
    w = _window(s, sm.LaserConfig(-math.pi / 4, math.pi / 4, 100.0, 0.0, 0.0, 0, 0.0))
    assert w.fan is None and (w.first, w.last, w.step) == (45, 135, 1)
    for lo_deg, hi_deg, r in ((-91.0, 0.0, 50.0), (10.0, -10.0, 50.0), (-10.5, 10.0, 30.0),
                              (-60.5, 60.0, 25.0)):
        with pytest.raises(ValueError):
            _window(s, sm.LaserConfig(math.radians(lo_deg), math.radians(hi_deg), r, 0.0, 0.0,
                                      0, 0.0))


def test_player_server_runs_at_real_time_unless_told_or_in_lockstep() -> None:
    assert default_speedup(None, lockstep=False) == 1.0
    assert default_speedup(None, lockstep=True) == 0.0
    assert default_speedup(0.0, lockstep=False) == 0.0
    assert default_speedup(5.0, lockstep=True) == 5.0
