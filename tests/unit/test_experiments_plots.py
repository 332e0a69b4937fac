"""Plots: down robots, labels that never overlap, legends of the states that occur, the
per-robot chart."""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib.pyplot as plt
import pytest

from experiments import events as ev
from experiments import timeline
from experiments.plots import (
    PLOT_FILES,
    plot_allocation,
    plot_battery,
    robot_shares,
    tasks_by_kind,
    write_plots,
)

E = ev.make_event


def _events() -> list[dict]:
    evs = [E(0.0, ev.RUN_START, experiment="boxpush", seed=1)]
    # many short tasks in a row: their labels cannot all fit
    for k in range(40):
        t = 5.0 * k
        evs.append(E(t, ev.TASK_INTRODUCED, task=f"user.{k}", task_kind="push-left-end"))
        evs.append(E(t + 0.1, ev.AWARD, task=f"user.{k}", robot="pusher1"))
        evs.append(E(t + 4.0, ev.TASK_OUTCOME, task=f"user.{k}", robot="pusher1",
                     outcome=ev.COMPLETED))
    evs += [
        E(1.0, ev.TASK_INTRODUCED, task="w", task_kind="watch-box"),
        E(1.5, ev.AWARD, task="w", robot="watcher"),
        E(40.0, ev.ROBOT_SWITCH_OFF, robot="pusher2"),
        E(150.0, ev.ROBOT_SWITCH_ON, robot="pusher2", x=0.0, y=0.0),
        E(160.0, ev.ROBOT_FAILURE, robot="pusher2", reason="killed"),
    ]
    evs.sort(key=lambda e: e["t"])
    evs.append(E(200.0, ev.RUN_END, wall_s=10.0, reason="completed"))
    return evs


ROBOTS = ("pusher1", "pusher2", "watcher")


def test_switched_off_and_killed_robots_are_down() -> None:
    ivs = timeline.robot_intervals(_events(), ROBOTS, end_s=200.0)
    p2 = [(iv.start_s, iv.end_s, iv.state) for iv in ivs["pusher2"]]
    assert p2 == [(0.0, 40.0, "idle"), (40.0, 150.0, "failed"), (150.0, 160.0, "idle"),
                  (160.0, 200.0, "failed")]


def _texts_per_row(fig) -> dict[float, list]:
    rows: dict[float, list] = {}
    for t in fig.axes[0].texts:
        rows.setdefault(round(t.get_position()[1], 3), []).append(t)
    return rows


def test_allocation_labels_never_overlap_and_the_legend_lists_states_that_occur() -> None:
    fig = plot_allocation(_events(), 200.0, ROBOTS)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    rows = _texts_per_row(fig)
    assert rows, "some labels fit"
    for texts in rows.values():
        boxes = sorted((t.get_window_extent(renderer) for t in texts), key=lambda b: b.x0)
        for a, b in itertools.pairwise(boxes):
            assert a.x1 <= b.x0, "labels overlap"
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert legend == ["working", "down"]  # nobody charged
    plt.close(fig)


def test_battery_shades_each_charging_trip() -> None:
    evs = [
        E(0.0, ev.BATTERY, percent={"p1": 90.0, "p2": 80.0}),
        E(100.0, ev.BATTERY, percent={"p1": 30.0, "p2": 70.0}),
        E(110.0, ev.CHARGE_START, robot="p1"),
        E(300.0, ev.CHARGE_END, robot="p1"),
        E(400.0, ev.BATTERY, percent={"p1": 95.0, "p2": 60.0}),
    ]
    fig = plot_battery(evs, 400.0)
    ax = fig.axes[0]
    bands = [p for p in ax.patches if p.get_label() == "charging"]
    assert len(bands) == 1 and bands[0].get_alpha() >= 0.2
    assert "1 charging trip" in ax.get_title()
    assert "charging" in [t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(fig)


def test_per_robot_shares_and_tasks_by_kind(tmp_path: Path) -> None:
    evs = _events()
    shares = robot_shares(evs, 200.0, ROBOTS)
    assert shares["pusher2"]["failed"] == pytest.approx(150.0 / 200.0)
    assert sum(shares["pusher1"].values()) == pytest.approx(1.0)
    assert tasks_by_kind(evs) == {"pusher1": {"push-left-end": 40}, "watcher": {"watch-box": 1}}
    paths = write_plots(evs, tmp_path, ROBOTS)
    assert [p.name for p in paths] == list(PLOT_FILES)
    assert (tmp_path / "robots.png").stat().st_size > 10_000


def test_the_live_label_names_the_task_and_its_target() -> None:
    tracker = timeline.RobotStateTracker()
    tracker.apply(E(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="cleanup",
                    params={"colour": "blue", "duration_s": 60}))
    tracker.apply(E(1.0, ev.TASK_INTRODUCED, task="t2", task_kind="sentry-duty",
                    params={"colour": "red", "x": 1, "y": -2.5}))
    tracker.apply(E(1.0, ev.TASK_INTRODUCED, task="t3", task_kind="goto-goal"))
    got = {}
    for task, robot in (("t1", "p1"), ("t2", "p2"), ("t3", "p3")):
        got.update(tracker.apply(E(2.0, ev.AWARD, task=task, robot=robot)))
    assert got["p1"].view_label == "cleanup: blue box"
    assert got["p2"].view_label == "sentry-duty: red object at spot (1.0, -2.5)"
    assert got["p3"].view_label == "goto-goal t3"
    assert tracker.state_of("p1").label == "cleanup t1"  # plots keep kind and id
    assert (got["p1"].target_colour, got["p3"].target_colour) == (0x0000FF, None)


def test_targets_are_named_by_colour_name_as_the_task_source_writes_them() -> None:
    tracker = timeline.RobotStateTracker()
    # the task source hands robots colours as "#rrggbb"; a person reads their names
    for task, colour in (("t1", "#ff8000"), ("t2", "#8000ff"), ("t3", "#fe0102")):
        tracker.apply(E(1.0, ev.TASK_INTRODUCED, task=task, task_kind="cleanup",
                        params={"colour": colour}))
    got = {}
    for task, robot in (("t1", "p1"), ("t2", "p2"), ("t3", "p3")):
        got.update(tracker.apply(E(2.0, ev.AWARD, task=task, robot=robot)))
    assert [got[r].view_label for r in ("p1", "p2", "p3")] == [
        "cleanup: orange box", "cleanup: purple box", "cleanup: red box"]  # nearest name
    assert got["p1"].target_colour == 0xFF8000
    tracker.apply(E(3.0, ev.TASK_INTRODUCED, task="u1", task_kind="watch-box",
                    params={"colour": "#ff8000", "goal_colour": "#ff00ff"}))
    watch = tracker.apply(E(3.0, ev.AWARD, task="u1", robot="w"))["w"]
    assert watch.view_label == "watch-box: orange box to the magenta marker"
