"""A run's plots as PNG files (matplotlib, Agg backend; no display needed).

    tasks.png       cumulative tasks introduced / allocated / completed / failed / unachievable
    battery.png     battery percent of every robot over simulation time
    allocation.png  one row per robot: working (with task labels), charging, failed
    box_distance.png  (boxpush) the box's distance to the goal, with switch-offs, switch-ons
                    and goal changes marked
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from experiments import events as ev
from experiments import timeline

STATE_COLOURS = {
    timeline.WORKING: "#f08c00",
    timeline.CHARGING: "#1fb84a",
    timeline.FAILED: "#7a7a7a",
}
PLOT_FILES = ("tasks.png", "battery.png", "allocation.png")
BOX_PLOT = "box_distance.png"


def _hours(t_s: float) -> float:
    return t_s / 3600.0


def _time_axis(ax: Any, end_s: float) -> str:
    return "simulation time (h)" if end_s >= 2 * 3600 else "simulation time (min)"


def _scale(end_s: float) -> float:
    return 3600.0 if end_s >= 2 * 3600 else 60.0


def plot_tasks(evs: list[Mapping[str, Any]], end_s: float) -> Figure:
    scale = _scale(end_s)
    series: dict[str, list[float]] = defaultdict(list)
    awarded: set[str] = set()
    for e in evs:
        k = e["kind"]
        if k == ev.TASK_INTRODUCED:
            series["introduced"].append(float(e["t"]))
        elif k == ev.AWARD and str(e["task"]) not in awarded:
            awarded.add(str(e["task"]))
            series["allocated"].append(float(e["t"]))
        elif k == ev.TASK_OUTCOME:
            series[str(e["outcome"])].append(float(e["t"]))
    fig, ax = plt.subplots(figsize=(9, 4.5), dpi=100)
    for name in ("introduced", "allocated", *ev.OUTCOMES):
        times = series.get(name, [])
        xs = [0.0] + [t / scale for t in times] + [end_s / scale]
        ys = [0, *range(1, len(times) + 1), len(times)]
        ax.step(xs, ys, where="post", label=f"{name} ({len(times)})")
    ax.set_xlabel(_time_axis(ax, end_s))
    ax.set_ylabel("tasks (cumulative)")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_title("Tasks over time")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    return fig


def plot_battery(evs: list[Mapping[str, Any]], end_s: float) -> Figure:
    scale = _scale(end_s)
    series: dict[str, tuple[list[float], list[float]]] = defaultdict(lambda: ([], []))
    for e in evs:
        if e["kind"] == ev.BATTERY:
            for robot, pct in e["percent"].items():
                xs, ys = series[str(robot)]
                xs.append(float(e["t"]) / scale)
                ys.append(float(pct))
    fig, ax = plt.subplots(figsize=(9, 4.5), dpi=100)
    for robot in sorted(series):
        xs, ys = series[robot]
        ax.plot(xs, ys, label=robot, linewidth=1.2)
    for e in evs:
        if e["kind"] == ev.CHARGE_START:
            ax.axvline(float(e["t"]) / scale, color="#1fb84a", alpha=0.15, linewidth=0.8)
    ax.set_ylim(0, 105)
    ax.set_xlim(0, max(end_s / scale, 1e-6))
    ax.set_xlabel(_time_axis(ax, end_s))
    ax.set_ylabel("battery (%)")
    ax.set_title("Battery of every robot (green lines: charge starts)")
    ax.grid(True, alpha=0.3)
    if series:
        ax.legend(loc="lower left", ncol=min(6, len(series)), fontsize="small")
    fig.tight_layout()
    return fig


def plot_allocation(
    evs: list[Mapping[str, Any]], end_s: float, robots: Iterable[str] = ()
) -> Figure:
    scale = _scale(end_s)
    intervals = timeline.robot_intervals(evs, robots, end_s=end_s)
    names = sorted(intervals)
    fig, ax = plt.subplots(figsize=(10, 1.0 + 0.55 * max(1, len(names))), dpi=100)
    span = end_s / scale
    for row, name in enumerate(names):
        for iv in intervals[name]:
            colour = STATE_COLOURS.get(iv.state)
            if colour is None:
                continue
            x0, w = iv.start_s / scale, (iv.end_s - iv.start_s) / scale
            ax.broken_barh([(x0, w)], (row - 0.38, 0.76), facecolors=colour, edgecolors="none")
            if iv.state == timeline.WORKING and span > 0 and w / span > 0.06:
                ax.text(x0 + w / 2, row, iv.label, ha="center", va="center", fontsize=7,
                        clip_on=True)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names)
    ax.set_ylim(-0.6, len(names) - 0.4)
    ax.set_xlim(0, max(span, 1e-6))
    ax.invert_yaxis()
    ax.set_xlabel(_time_axis(ax, end_s))
    ax.set_title("Allocation timeline per robot", loc="left")
    labels = {timeline.FAILED: "down"}
    ax.legend(handles=[Patch(color=c, label=labels.get(s, s)) for s, c in STATE_COLOURS.items()],
              loc="lower right", bbox_to_anchor=(1.0, 1.0), fontsize="small", ncol=3,
              frameon=False)
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def plot_box_distance(evs: list[Mapping[str, Any]], radius_m: float | None = None) -> Figure:
    """The box's ground-truth distance to the (current) goal over simulation time."""
    track = [(float(e["t"]), float(e["distance_m"])) for e in evs if e["kind"] == ev.BOX_PROGRESS]
    fig, ax = plt.subplots(figsize=(9, 4.0), dpi=100)
    ax.plot([t for t, _ in track], [d for _, d in track], color="#f08c00", linewidth=1.6,
            label="box to goal")
    marks = {ev.ROBOT_SWITCH_OFF: ("#7a7a7a", "off"), ev.ROBOT_SWITCH_ON: ("#1fb84a", "on"),
             ev.GOAL_MOVED: ("#c2255c", "new goal")}
    for e in evs:
        if e["kind"] in marks:
            colour, what = marks[str(e["kind"])]
            who = e.get("robot") or e.get("marker") or ""
            ax.axvline(float(e["t"]), color=colour, linestyle="--", linewidth=1.0)
            ax.text(float(e["t"]), 0.02, f" {who} {what}", rotation=90, va="bottom",
                    fontsize=8, color=colour, transform=ax.get_xaxis_transform())
    if radius_m is None:
        reached = next((e for e in evs if e["kind"] == ev.GOAL_REACHED), None)
        radius_m = float(reached["radius_m"]) if reached and "radius_m" in reached else None
    if radius_m is not None:
        ax.axhline(radius_m, color="#1c7ed6", linewidth=0.8, label="goal radius")
    ax.set_xlabel("simulation time (s)")
    ax.set_ylabel("distance to the goal (m)")
    ax.set_ylim(bottom=0)
    ax.set_title("Box distance to the goal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize="small")
    fig.tight_layout()
    return fig


def write_plots(
    evs: Iterable[Mapping[str, Any]], out_dir: Path, robots: Iterable[str] = ()
) -> list[Path]:
    """Write the three PNGs into `out_dir`; returns their paths."""
    evs = [e for e in evs if e["kind"] != ev.POSES]
    end_s = max((float(e["t"]) for e in evs), default=0.0)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for filename, fig in zip(
        PLOT_FILES,
        (plot_tasks(evs, end_s), plot_battery(evs, end_s),
         plot_allocation(evs, end_s, robots)),
        strict=True,
    ):
        path = out_dir / filename
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    if any(e["kind"] == ev.BOX_PROGRESS for e in evs):
        fig = plot_box_distance(evs)
        path = out_dir / BOX_PLOT
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    return paths
