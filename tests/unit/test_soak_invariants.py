"""The soak invariants on hand-made events: each holds on a clean story and breaks, with its
first counter-example, on a broken one; the fault schedule is seeded and well formed."""

from __future__ import annotations

import json
import random
from pathlib import Path
from typing import Any

import pytest

from experiments.soak.faults import (
    FaultFileError,
    FaultMix,
    draw_schedule,
    fault_to_dict,
    load_schedule,
)
from experiments.soak.invariants import (
    DEAD_GRACE_S,
    Limits,
    check_dead_controllers,
    check_events,
    dead_spans,
    memory_slopes,
    slope_per_hour,
)

LIMITS = Limits(realloc_bound_s=13.0, charge_bound_s=600.0, memory_slope_mib_per_h=2.0)


def e(t: float, kind: str, **fields: Any) -> dict[str, Any]:
    return {"t": t, "kind": kind, **fields}


def story() -> list[dict[str, Any]]:
    """p1 wins t1, is killed, the task goes back to auction after 10 s and p2 finishes it."""
    return [
        e(0.0, "run_start", experiment="longterm", seed=1),
        e(5.0, "task_introduced", task="t1", task_kind="sentry-duty"),
        e(6.0, "award", task="t1", robot="p1", latency_s=1.0),
        e(6.2, "robot_task", robot="p1", phase="start", task="t1"),
        e(30.0, "robot_failure", robot="p1", reason="killed"),
        e(40.0, "reallocation", task="t1", from_robot="p1", reason="silent"),
        e(41.0, "award", task="t1", robot="p2", latency_s=1.0),
        e(41.2, "robot_task", robot="p2", phase="start", task="t1"),
        e(60.0, "robot_restart", robot="p1"),
        e(90.0, "robot_task", robot="p2", phase="done", task="t1"),
        e(90.1, "task_outcome", task="t1", outcome="completed", robot="p2"),
        e(100.0, "run_end", reason="completed"),
    ]


def test_a_clean_story_holds_every_event_invariant() -> None:
    inv = check_events(story(), LIMITS)
    assert all(v.held for v in inv.verdicts.values()), inv.verdicts
    (lat,) = inv.realloc_latencies
    assert lat["latency_s"] == pytest.approx(10.0) and lat["how"] == "reallocated"


def test_a_second_outcome_and_an_open_task_break_terminal_states() -> None:
    events = [*story()[:-1], e(95.0, "task_outcome", task="t1", outcome="failed"),
              e(96.0, "task_introduced", task="t2", task_kind="cleanup")]
    v = check_events(events, LIMITS).verdicts["terminal_states"]
    assert not v.held and v.breaches == 2
    assert v.first_counter_example == {"t": 95.0, "task": "t1",
                                       "problem": "a second terminal state",
                                       "outcome": "failed"}


def test_two_robots_executing_one_task_is_a_breach() -> None:
    events = [e(1.0, "task_introduced", task="t1", task_kind="cleanup"),
              e(2.0, "robot_task", robot="p1", phase="start", task="t1"),
              e(3.0, "robot_task", robot="p2", phase="start", task="t1"),
              e(9.0, "robot_task", robot="p2", phase="done", task="t1"),
              e(9.1, "task_outcome", task="t1", outcome="completed")]
    v = check_events(events, LIMITS).verdicts["exclusive_execution"]
    assert not v.held
    assert v.first_counter_example == {"t": 3.0, "task": "t1", "robots": ["p1", "p2"]}


def group_story(third: bool) -> list[dict[str, Any]]:
    """A group task taken whole by p1 and p2 (two seats); with `third`, p3 joins in."""
    params = {"required": 2, "members": [{"kind": "watch-object-side"}] * 2}
    events = [e(1.0, "task_introduced", task="group-1", task_kind="watch-object-pair",
                source="user", group=True),
              e(1.0, "task_introduced", task="u.1", task_kind="watch-object-pair",
                source="group", parent="group-1", params=params),
              e(2.0, "award", task="u.1", robot="p1", seat=0),
              e(2.0, "award", task="u.1", robot="p2", seat=1),
              e(2.1, "robot_task", robot="p1", phase="start", task="u.1"),
              e(2.1, "robot_task", robot="p2", phase="start", task="u.1")]
    if third:
        events.append(e(3.0, "robot_task", robot="p3", phase="start", task="u.1"))
    return [*events,
            e(30.0, "robot_failure", robot="p2", reason="killed"),
            e(35.0, "reallocation", task="u.1", from_robot="p2", reason="silent"),
            e(50.0, "task_outcome", task="u.1", outcome="completed"),
            e(50.0, "task_outcome", task="group-1", outcome="completed")]


def test_a_group_task_is_executed_by_its_group_and_no_more() -> None:
    inv = check_events(group_story(third=False), LIMITS)
    assert all(v.held for v in inv.verdicts.values()), inv.verdicts
    (lat,) = inv.realloc_latencies  # the killed member's task went back (whole)
    assert lat["robot"] == "p2" and lat["latency_s"] == pytest.approx(5.0)
    v = check_events(group_story(third=True), LIMITS).verdicts["exclusive_execution"]
    assert not v.held
    assert v.first_counter_example == {"t": 3.0, "task": "u.1", "robots": ["p1", "p2", "p3"]}


def test_a_thawed_holder_that_lets_go_at_once_is_no_overlap() -> None:
    events = [e(1.0, "task_introduced", task="t1", task_kind="cleanup"),
              e(2.0, "award", task="t1", robot="p1"),
              e(2.2, "robot_task", robot="p1", phase="start", task="t1"),
              e(10.0, "robot_freeze", robot="p1"),
              e(19.5, "reallocation", task="t1", from_robot="p1", reason="silent"),
              e(20.5, "award", task="t1", robot="p2"),
              e(20.7, "robot_task", robot="p2", phase="start", task="t1"),
              e(40.0, "robot_thaw", robot="p1"),
              e(40.2, "robot_task", robot="p1", phase="stopped", task="t1"),
              e(80.0, "robot_task", robot="p2", phase="done", task="t1"),
              e(80.1, "task_outcome", task="t1", outcome="completed")]
    inv = check_events(events, LIMITS)
    assert inv.verdicts["exclusive_execution"].held
    assert inv.verdicts["reallocation_bound"].held
    # but one that keeps going breaks it
    keeps = [x for x in events if not (x["kind"] == "robot_task" and x["robot"] == "p1"
                                       and x["phase"] == "stopped")]
    v = check_events(keeps, LIMITS).verdicts["exclusive_execution"]
    assert not v.held and v.first_counter_example["t"] == 40.0


def test_a_frozen_holder_back_before_the_timeout_keeps_its_task() -> None:
    events = [e(1.0, "task_introduced", task="t1", task_kind="cleanup"),
              e(2.0, "award", task="t1", robot="p1"),
              e(10.0, "robot_freeze", robot="p1"),
              e(15.0, "robot_thaw", robot="p1"),
              e(50.0, "task_outcome", task="t1", outcome="completed")]
    inv = check_events(events, LIMITS)
    assert inv.verdicts["reallocation_bound"].held
    assert inv.realloc_latencies[0]["how"] == "holder continued"


def test_a_reallocation_later_than_the_bound_breaks_it() -> None:
    events = story()
    late = [x if x["kind"] != "reallocation" else {**x, "t": 45.0} for x in events]
    v = check_events(late, LIMITS).verdicts["reallocation_bound"]
    assert not v.held
    assert v.first_counter_example["task"] == "t1"
    assert v.first_counter_example["robot"] == "p1"
    assert v.first_counter_example["cause"] == "killed"
    # never reallocated at all: found at the end
    never = [x for x in events if x["kind"] not in ("reallocation",)]
    assert not check_events(never, LIMITS).verdicts["reallocation_bound"].held


def test_a_robot_low_on_battery_must_reach_a_charger() -> None:
    low = [e(0.0, "run_start", experiment="longterm", seed=1),
           e(30.0, "battery", percent={"p1": 24.0, "p2": 80.0}),
           e(200.0, "charge_start", robot="p1"),
           e(800.0, "run_end", reason="completed")]
    assert check_events(low, LIMITS).verdicts["charging"].held
    never = [x for x in low if x["kind"] != "charge_start"]
    v = check_events(never, LIMITS).verdicts["charging"]
    assert not v.held and v.first_counter_example["robot"] == "p1"
    assert v.first_counter_example["t"] == 30.0
    # a charger outage in between stretches the bound
    outage = [*never[:2], e(40.0, "charger_off", charger="dock_sw"),
              e(400.0, "charger_on", charger="dock_sw"), e(800.0, "charge_start", robot="p1"),
              e(900.0, "run_end", reason="completed")]
    assert check_events(outage, LIMITS).verdicts["charging"].held
    # a dead robot need not
    dead = [*never[:2], e(35.0, "robot_failure", robot="p1", reason="killed"), never[-1]]
    assert check_events(dead, LIMITS).verdicts["charging"].held


def test_a_robot_moving_with_a_dead_controller_is_found() -> None:
    events = [e(10.0, "robot_failure", robot="p1", reason="killed"),
              e(50.0, "robot_restart", robot="p1"),
              e(60.0, "robot_switch_off", robot="p2", permanent=True)]
    spans = dead_spans(events, 100.0)
    assert spans == {"p1": [(10.0, 50.0)], "p2": [(60.0, 100.0)]}
    still = [("p1", t, 0.0, 0.0) for t in (5.0, 12.0 + DEAD_GRACE_S, 30.0)]
    # moving inside the watchdog's grace, and after the restart, is fine
    fine = [*still, ("p1", 11.0, 0.3, 0.0), ("p1", 55.0, 0.3, 0.1)]
    assert check_dead_controllers(spans, fine).held
    broken = check_dead_controllers(spans, [*fine, ("p2", 90.0, 0.0, 0.4),
                                            ("p2", 70.0, 0.2, 0.0)])
    assert not broken.held and broken.breaches == 2
    assert broken.first_counter_example["robot"] == "p2"
    assert broken.first_counter_example["t"] == 70.0


def test_memory_slope_over_the_second_half() -> None:
    assert slope_per_hour([(0.0, 10.0), (3600.0, 12.0), (7200.0, 14.0)]) == pytest.approx(2.0)
    flat = [{"kind": "process", "t": float(t), "name": "runner", "pid": 1,
             "rss_bytes": (200 << 20) + (t % 7) * 1000} for t in range(0, 7200, 60)]
    # early growth (warming up) does not count, only the second half
    warm = [{**s, "rss_bytes": s["rss_bytes"] - ((3600 - s["t"]) * 5000 if s["t"] < 3600
                                                 else 0)} for s in flat]
    v, per = memory_slopes(warm, 7200.0, 2.0)
    assert v.held and v.checked and abs(per["runner"]["slope_mib_per_h"]) < 0.1
    leak = [{**s, "rss_bytes": s["rss_bytes"] + int(s["t"] * 1500)} for s in flat]
    v, per = memory_slopes(leak, 7200.0, 2.0)
    assert not v.held
    assert v.first_counter_example["process"] == "runner"
    assert per["runner"]["slope_mib_per_h"] == pytest.approx(1500 * 3600 / (1 << 20), rel=0.01)
    v, _ = memory_slopes(flat[:3], 7200.0, 2.0)
    assert not v.checked and v.held
    # a robot restarted late warms up (its first simulated minutes are not judged)
    restarted = [{"kind": "process_note", "what": "started", "t": 5400.0, "robot": "p1",
                  "pid": 7},
                 *({"kind": "process", "t": float(t), "name": "robot-p1", "pid": 7,
                    "rss_bytes": (20 << 20) + min(t - 5400, 300) * 10_000}
                   for t in range(5400, 7200, 30))]
    v, per = memory_slopes([*flat, *restarted], 7200.0, 2.0)
    assert v.held and abs(per["robot-p1"]["slope_mib_per_h"]) < 0.1
    # a host of seven robots growing 7 MiB/h grows 1 MiB/h per robot: within the limit; its
    # robots restarted later do not move its warm-up (its first start counts)
    host = [{"kind": "process_note", "what": "started", "t": 0.0, "robot": "p1", "pid": 9},
            {"kind": "process_note", "what": "started", "t": 6000.0, "robot": "p2", "pid": 9},
            *({"kind": "process", "t": float(t), "name": "host-0", "pid": 9, "robots": 7,
               "rss_bytes": (50 << 20) + int(t * 7 * (1 << 20) / 3600)}
              for t in range(0, 7200, 60))]
    v, per = memory_slopes(host, 7200.0, 2.0)
    assert v.held and per["host-0"]["robots"] == 7 and per["host-0"]["samples"] == 60
    assert per["host-0"]["slope_mib_per_h"] == pytest.approx(1.0, rel=0.01)
    v, per = memory_slopes(host, 7200.0, 0.5)
    assert not v.held and v.first_counter_example["process"] == "host-0"
    # a process there from the start is judged from WARMUP_S, however late its first
    # sample came (a fast run's first wall seconds cover simulated minutes)
    late = [{"kind": "process", "t": t, "name": "runner", "pid": 1, "rss_bytes": 200 << 20}
            for t in (300.0, 650.0, 700.0, 800.0, 900.0)]
    v, per = memory_slopes(late, 900.0, 2.0)
    assert v.checked and per["runner"]["samples"] == 4


def test_the_random_schedule_is_seeded_and_its_robot_episodes_never_overlap() -> None:
    mix = FaultMix(kills_per_h=3, freezes_per_h=3, charger_outages_per_h=2, bursts=2)
    a = draw_schedule(random.Random(5), 7200.0, ["p1", "p2", "p3"], ["c1", "c2"], mix)
    b = draw_schedule(random.Random(5), 7200.0, ["p1", "p2", "p3"], ["c1", "c2"], mix)
    assert a == b
    actions = [f.action for f in a]
    for action in ("kill", "restart", "freeze", "thaw", "retire", "charger-off",
                   "charger-on", "burst"):
        assert action in actions
    assert all(mix.quiet_start_s <= f.t_s <= 7200.0 - mix.quiet_end_s for f in a)
    # kill..restart and freeze..thaw episodes alternate, one at a time
    episode = [f for f in a if f.action in ("kill", "restart", "freeze", "thaw")]
    for start, end in zip(episode[::2], episode[1::2], strict=True):
        assert (start.action, end.action) in (("kill", "restart"), ("freeze", "thaw"))
    (retire,) = [f for f in a if f.action == "retire"]
    assert not any(s.t_s - 1 <= retire.t_s <= t.t_s + 1
                   for s, t in zip(episode[::2], episode[1::2], strict=True))
    outages = [f for f in a if f.action.startswith("charger")]
    for off, on in zip(outages[::2], outages[1::2], strict=True):
        assert off.action == "charger-off" and on.action == "charger-on"
        assert off.robot == on.robot


def test_a_schedule_file_round_trips_and_bad_entries_are_named(tmp_path: Path) -> None:
    mix = FaultMix(bursts=1)
    faults = draw_schedule(random.Random(2), 7200.0, ["p1", "p2"], ["c1"], mix)
    path = tmp_path / "faults.json"
    path.write_text(json.dumps({"faults": [fault_to_dict(f) for f in faults]}))
    assert load_schedule(path, ["p1", "p2"], ["c1"]) == faults
    bad = [({"t_s": 1, "action": "explode", "robot": "p1"}, "action must be one of"),
           ({"t_s": -1, "action": "kill", "robot": "p1"}, "t_s must be"),
           ({"t_s": 1, "action": "kill", "robot": "p9"}, "robot must be one of"),
           ({"t_s": 1, "action": "charger-off", "robot": "p1"}, "must name a charger"),
           ({"t_s": 1, "action": "burst", "count": 0}, "count must be")]
    for entry, message in bad:
        path.write_text(json.dumps([entry]))
        with pytest.raises(FaultFileError, match=message) as info:
            load_schedule(path, ["p1", "p2"], ["c1"])
        assert str(path) in str(info.value) and "fault 0" in str(info.value)
    path.write_text("{not json")
    with pytest.raises(FaultFileError, match="not JSON"):
        load_schedule(path, ["p1"], ["c1"])
