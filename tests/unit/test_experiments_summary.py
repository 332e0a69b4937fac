"""Summary counts, robot timelines, progress figures and plots from a hand-written event log."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from experiments import events as ev
from experiments import timeline
from experiments.plots import PLOT_FILES, write_plots
from experiments.progress import ProgressDisplay, ProgressTracker, format_line
from experiments.registry import experiment
from experiments.summary import summarize, terminal_state_problems

E = ev.make_event


def run_events() -> list[dict]:
    return [
        E(0.0, ev.RUN_START, experiment="longterm", seed=3),
        E(0.0, ev.PROCESS, name="server", pid=10, rss_bytes=100, peak_rss_bytes=120),
        E(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="sentry-duty"),
        E(1.0, ev.MESSAGE, msg_kind="announce", sender="user", task="t1", bytes=200),
        E(1.1, ev.MESSAGE, msg_kind="bid", sender="p1", task="t1", bytes=150),
        E(1.2, ev.MESSAGE, msg_kind="bid", sender="p2", task="t1", bytes=150),
        E(1.5, ev.AWARD, task="t1", robot="p1"),
        E(2.0, ev.TASK_INTRODUCED, task="t2", task_kind="cleanup"),
        E(2.0, ev.AWARD, task="t2", robot="p2", latency_s=0.25),
        E(3.0, ev.BATTERY, percent={"p1": 80.0, "p2": 60.0}),
        E(4.0, ev.ROBOT_FAILURE, robot="p2"),
        E(4.0, ev.REALLOCATION, task="t2", from_robot="p2", reason="killed"),
        E(4.5, ev.AWARD, task="t2", robot="p3", latency_s=0.5),
        E(5.0, ev.TASK_OUTCOME, task="t1", robot="p1", outcome=ev.COMPLETED),
        E(5.5, ev.CHARGE_START, robot="p1"),
        E(6.0, ev.BATTERY, percent={"p1": 20.0, "p3": 70.0}),
        E(7.0, ev.TASK_INTRODUCED, task="t3", task_kind="object-tracking"),
        E(8.0, ev.TASK_OUTCOME, task="t3", outcome=ev.UNACHIEVABLE, reason="no bids"),
        E(9.0, ev.CHARGE_END, robot="p1"),
        E(9.5, ev.ROBOT_RESTART, robot="p2"),
        E(10.0, ev.TASK_OUTCOME, task="t2", robot="p3", outcome=ev.COMPLETED),
        E(10.0, ev.PROCESS, name="server", pid=10, rss_bytes=110, peak_rss_bytes=130),
        E(10.0, ev.RUN_END, wall_s=0.5, reason="completed"),
    ]


def test_summary_counts() -> None:
    s = summarize(run_events())
    assert s["experiment"] == "longterm" and s["seed"] == 3
    assert s["tasks"]["introduced"] == 3
    assert s["tasks"]["allocated"] == 2
    assert s["tasks"]["executed"] == 2
    assert s["tasks"]["unachievable"] == 1
    assert s["tasks"]["failed"] == 0
    assert s["tasks"]["reallocations"] == 1
    assert s["tasks"]["by_kind"]["cleanup"] == {"completed": 1, "introduced": 1}
    assert s["charging_trips"] == 1
    assert s["robot_failures"] == 1 and s["robot_restarts"] == 1
    assert s["messages"]["by_kind"] == {
        "announce": {"count": 1, "bytes": 200},
        "bid": {"count": 2, "bytes": 300},
    }
    assert s["messages"]["total_bytes"] == 500
    lat = s["auction_latency_s"]
    assert lat["count"] == 3  # 0.5 (announce -> award), 0.25, 0.5
    assert lat["median"] == pytest.approx(0.5)
    assert lat["max"] == pytest.approx(0.5)
    assert s["real_time_factor"] == pytest.approx(20.0)
    assert s["lowest_battery_percent"] == 20.0
    assert s["processes"]["server"]["peak_rss_bytes"] == 130
    assert s["processes"]["server"]["rss_first_bytes"] == 100
    assert s["processes"]["server"]["rss_last_bytes"] == 110
    assert s["robots"]["p1"] == {"awards": 1, "charging_trips": 1, "tasks_completed": 1}
    assert s["invariant_terminal_states"]["holds"] is True


def test_charging_trips_are_completed_cycles() -> None:
    evs = [
        E(0.0, ev.RUN_START, experiment="longterm", seed=1),
        # p1 docks three times before it finishes one charge: one trip
        E(1.0, ev.CHARGE_START, robot="p1"),
        E(2.0, ev.CHARGE_START, robot="p1"),
        E(3.0, ev.CHARGE_START, robot="p1"),
        E(4.0, ev.CHARGE_END, robot="p1"),
        # p2: two full cycles, then one cut off by the end of the run
        E(1.0, ev.CHARGE_START, robot="p2"),
        E(2.0, ev.CHARGE_END, robot="p2"),
        E(5.0, ev.CHARGE_START, robot="p2"),
        E(6.0, ev.CHARGE_END, robot="p2"),
        E(7.0, ev.CHARGE_START, robot="p2"),
        # p3: killed while charging, its end never comes; a stray end counts nothing
        E(1.0, ev.CHARGE_START, robot="p3"),
        E(2.0, ev.ROBOT_FAILURE, robot="p3"),
        E(3.0, ev.CHARGE_END, robot="p3"),
    ]
    s = summarize(evs)
    assert s["charging_trips"] == 3
    assert s["charging_starts"] == 7
    assert s["robots"]["p1"]["charging_trips"] == 1
    assert s["robots"]["p2"]["charging_trips"] == 2
    assert "charging_trips" not in s["robots"].get("p3", {})


def test_first_attempt_unallocatable_apart_from_unachievable_after_backoff() -> None:
    evs = [
        E(0.0, ev.RUN_START, experiment="longterm", seed=1),
        E(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="cleanup", source="user"),
        E(2.0, ev.NO_BID, task="t1", attempt=1),
        E(9.0, ev.AWARD, task="t1", robot="p3"),          # allocated after backoff
        E(1.5, ev.TASK_INTRODUCED, task="t2", task_kind="cleanup", source="user"),
        E(2.5, ev.NO_BID, task="t2", attempt=1),
        E(8.0, ev.NO_BID, task="t2", attempt=2),
        E(300.0, ev.TASK_OUTCOME, task="t2", outcome=ev.UNACHIEVABLE),
        E(3.0, ev.TASK_INTRODUCED, task="t3", task_kind="sentry-duty", source="user"),
        E(4.0, ev.AWARD, task="t3", robot="p1"),
        E(5.0, ev.REALLOCATION, task="t3", from_robot="p1", reason="silent"),
        E(6.0, ev.NO_BID, task="t3", attempt=2),           # not its first auction
        E(6.0, ev.TASK_INTRODUCED, task="r1", task_kind="push-left-end", source="watcher"),
        E(6.5, ev.NO_BID, task="r1", attempt=1),
    ]
    tasks = summarize(evs)["tasks"]
    assert tasks["first_attempt_unallocatable"] == 2
    assert tasks["then_allocated"] == 1
    assert tasks["unachievable_after_backoff"] == 1
    assert tasks["subtasks"] == {"first_attempt_unallocatable": 1, "then_allocated": 0,
                                 "unachievable_after_backoff": 0}
    waits = summarize(evs)["waits_s"]
    assert waits["count"] == 2 and waits["max"] == pytest.approx(8.0)
    assert waits["never_awarded"] == 1


def test_pushes_per_end_per_pusher_before_alone_and_after() -> None:
    evs = [E(0.0, ev.RUN_START, experiment="boxpush", seed=1)]
    for i, (t, kind, robot) in enumerate([
        (5, "push-left-end", "pusher1"), (6, "push-right-end", "pusher2"),
        (12, "push-left-end", "pusher1"), (30, "push-left-end", "pusher2"),
        (35, "push-right-end", "pusher2"), (70, "push-right-end", "pusher1"),
        (71, "push-left-end", "pusher2"), (80, "push-right-end", "pusher1"),
    ]):
        evs += [E(t, ev.TASK_INTRODUCED, task=f"w{i}", task_kind=kind, source="watcher"),
                E(t + 0.5, ev.AWARD, task=f"w{i}", robot=robot)]
    evs += [E(20.0, ev.ROBOT_SWITCH_OFF, robot="pusher1"),
            E(60.0, ev.ROBOT_SWITCH_ON, robot="pusher1", x=0.0, y=0.0),
            E(61.0, ev.BOX_PROGRESS, distance_m=4.0), E(62.0, ev.BOX_PROGRESS, distance_m=3.5)]
    goal = summarize(sorted(evs, key=lambda e: e["t"]), (),
                     experiment("boxpush"))["goal"]
    assert goal["pushes"]["phases"] == {
        "before": {"pusher1": {"left": 2}, "pusher2": {"right": 1}},
        "alone": {"pusher2": {"left": 1, "right": 1}},
        "after": {"pusher1": {"right": 2}, "pusher2": {"left": 1}},
    }
    assert goal["pushes"]["role_swap"] == {"robot": "pusher1", "end_before": "left",
                                           "end_after": "right", "swapped": True}
    assert goal["final_distance_m"] == 3.5


def test_terminal_state_problems_are_reported() -> None:
    evs = [
        *run_events(),
        E(11.0, ev.TASK_INTRODUCED, task="t4", task_kind="cleanup"),
        E(12.0, ev.TASK_OUTCOME, task="t1", outcome=ev.FAILED),
        E(12.0, ev.TASK_OUTCOME, task="t9", outcome=ev.FAILED),
    ]
    problems = terminal_state_problems(evs)
    assert problems == {
        "without_outcome": ["t4"],
        "several_outcomes": ["t1"],
        "never_introduced": ["t9"],
    }
    assert summarize(evs)["invariant_terminal_states"]["holds"] is False


def test_robot_intervals() -> None:
    ivs = timeline.robot_intervals(run_events(), robots=("p1", "p2", "p3", "p4"))
    p1 = [(i.start_s, i.end_s, i.state, i.label) for i in ivs["p1"]]
    assert p1 == [
        (0.0, 1.5, "idle", ""),
        (1.5, 5.0, "working", "sentry-duty t1"),
        (5.0, 5.5, "idle", ""),
        (5.5, 9.0, "charging", ""),
        (9.0, 10.0, "idle", ""),
    ]
    p2 = [(i.start_s, i.end_s, i.state) for i in ivs["p2"]]
    assert p2 == [(0.0, 2.0, "idle"), (2.0, 4.0, "working"), (4.0, 9.5, "failed"),
                  (9.5, 10.0, "idle")]
    assert [i.state for i in ivs["p4"]] == ["idle"]


def test_tracker_reports_only_changes() -> None:
    tr = timeline.RobotStateTracker()
    tr.apply(E(0, ev.TASK_INTRODUCED, task="t1", task_kind="cleanup"))
    changed = tr.apply(E(1, ev.AWARD, task="t1", robot="p1"))
    assert changed == {"p1": timeline.RobotState("working", "cleanup t1", "t1")}
    # an award of the same task to another robot takes it from the first
    changed = tr.apply(E(2, ev.AWARD, task="t1", robot="p2"))
    assert changed["p1"].state == "idle" and changed["p2"].state == "working"
    assert tr.apply(E(3, ev.BATTERY, percent={"p1": 50})) == {}
    # charging wins over working; the task comes back after charging
    tr.apply(E(4, ev.CHARGE_START, robot="p2"))
    assert tr.state_of("p2").state == "charging"
    tr.apply(E(5, ev.CHARGE_END, robot="p2"))
    assert tr.state_of("p2").state == "working"


def test_progress_figures_and_plain_lines() -> None:
    tracker = ProgressTracker(robots=("p1", "p2", "p3"))
    wall = [0.0]
    out = io.StringIO()
    display = ProgressDisplay(tracker, wall_clock=lambda: wall[0], stream=out, terminal=False,
                              line_period_sim_s=300.0, title="murdoch longterm")
    display.start()
    assert out.getvalue() == "murdoch longterm: started\n"  # at once
    for e in run_events()[:16]:  # up to the second battery sample, p1 charging
        tracker.apply(e)
    wall[0] = 0.5
    display.tick()
    assert len(out.getvalue().splitlines()) == 1
    wall[0] = 2.0
    p = display.snapshot()
    assert (p.introduced, p.allocated, p.completed, p.unachievable) == (2, 2, 1, 0)
    assert p.charging == 1 and p.failed_robots == 1 and p.lowest_battery_percent == 20.0
    assert p.real_time_factor == pytest.approx(3.0)
    display.tick()  # a second has passed: the first figures
    display.tick()
    assert len(out.getvalue().splitlines()) == 2  # not yet five simulated minutes
    tracker.advance(301.0)
    display.tick()
    display.tick()
    tracker.advance(1000.0)  # several periods at once give one line
    display.tick()
    last = display.stop()
    lines = out.getvalue().splitlines()
    assert len(lines) == 5
    assert lines[1].startswith("sim 0:00:06 | wall 0:00:02 | rtf 3.0 | tasks introduced 2")
    assert lines[2].startswith("sim 0:05:01 | wall 0:00:02 | rtf 150.5 | tasks introduced 2")
    assert "charging 1 | lowest battery 20%" in lines[2]
    assert lines[-1] == format_line(last)


def test_progress_lines_show_the_eta_when_the_length_is_known() -> None:
    tracker = ProgressTracker()
    wall = [0.0]
    out = io.StringIO()
    display = ProgressDisplay(tracker, wall_clock=lambda: wall[0], stream=out, terminal=False,
                              duration_s=1800.0, title="murdoch longterm")
    display.start()
    assert out.getvalue() == "murdoch longterm: started for 0:30:00 simulated\n"
    tracker.advance(600.0)
    wall[0] = 20.0  # 30x real time: 1200 s left take 40 s
    display.tick()
    line = out.getvalue().splitlines()[1]
    assert line.startswith("sim 0:10:00 / 0:30:00   33%  ETA 0:00:40 | wall 0:00:20")
    display.stop()


def test_progress_live_table_on_a_terminal() -> None:
    tracker = ProgressTracker()
    out = io.StringIO()
    display = ProgressDisplay(tracker, wall_clock=lambda: 1.0, stream=out, terminal=True,
                              refresh_per_second=20)
    assert display.terminal
    with display:
        for e in run_events():
            tracker.apply(e)
        display.tick()
    text = out.getvalue()
    assert "tasks introduced" in text and "lowest battery" in text and "20%" in text


def test_progress_bar_with_eta_on_a_terminal() -> None:
    tracker = ProgressTracker()
    wall = [0.0]
    out = io.StringIO()
    display = ProgressDisplay(tracker, wall_clock=lambda: wall[0], stream=out, terminal=True,
                              refresh_per_second=20, duration_s=600.0)
    with display:
        tracker.advance(300.0)
        wall[0] = 10.0
    text = out.getvalue()
    assert "sim 0:05:00 / 0:10:00   50%  ETA 0:00:10" in text
    assert "━" in text  # the bar itself


def test_plots_are_written(tmp_path: Path) -> None:
    paths = write_plots(run_events(), tmp_path / "plots", robots=("p1", "p2", "p3", "p4"))
    assert [p.name for p in paths] == list(PLOT_FILES)
    for p in paths:
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def test_plots_of_an_empty_run(tmp_path: Path) -> None:
    paths = write_plots([], tmp_path, robots=("p1",))
    assert all(p.stat().st_size > 1000 for p in paths)


def test_tasks_open_when_the_run_ends_are_open_at_end_not_failed() -> None:
    evs = [
        E(0.0, ev.RUN_START, experiment="longterm", seed=1),
        E(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="sentry-duty"),
        E(1.0, ev.TASK_INTRODUCED, task="t2", task_kind="cleanup"),
        E(1.0, ev.TASK_INTRODUCED, task="t3", task_kind="cleanup"),
        E(1.0, ev.TASK_INTRODUCED, task="t4", task_kind="cleanup"),
        E(2.0, ev.AWARD, task="t1", robot="p1"),
        E(5.0, ev.TASK_OUTCOME, task="t2", outcome=ev.FAILED, reason="robot stuck"),
        E(9.0, ev.TASK_OUTCOME, task="t1", robot="p1", outcome=ev.FAILED, reason="run ended"),
        E(9.0, ev.TASK_OUTCOME, task="t3", outcome=ev.FAILED,
          reason="run ended: box at the goal"),
        E(9.0, ev.TASK_OUTCOME, task="t4", outcome=ev.OPEN_AT_END, reason="run ended"),
        E(9.0, ev.RUN_END, wall_s=1.0, reason="completed"),
    ]
    s = summarize(evs)
    assert s["tasks"]["failed"] == 1
    assert s["tasks"]["open_at_end"] == 3
    assert s["tasks"]["by_kind"]["cleanup"] == {"failed": 1, "introduced": 3, "open_at_end": 2}
    assert s["invariant_terminal_states"]["holds"]
    tracker = ProgressTracker(("p1",))
    for e in evs:
        tracker.apply(e)
    p = tracker.progress(1.0)
    assert p.failed == 1
    assert ev.counted_outcome({"outcome": "completed", "reason": "run ended"}) == "completed"
