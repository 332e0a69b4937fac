"""A run's plots as PNG files (matplotlib, Agg backend; no display needed).

    tasks.png       cumulative tasks introduced / allocated / completed / failed / unachievable /
                    open at the end
    battery.png     battery percent of every robot over simulation time, charging shaded
    allocation.png  one row per robot: working (with task labels where they fit), charging,
                    down (killed or switched off); the legend lists the states that occur
    robots.png      per robot: tasks won by kind, and the share of time idle / working /
                    charging / down
    box_distance.png  (boxpush) the box's distance to the goal, with switch-offs, switch-ons
                    and goal changes marked
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from experiments import events as ev
from experiments import timeline

if TYPE_CHECKING:
    from experiments.plugin import Experiment
from experiments.summary import first_awards

STATE_COLOURS = {
    timeline.WORKING: "#f08c00",
    timeline.CHARGING: "#1fb84a",
    timeline.FAILED: "#7a7a7a",
}
IDLE_COLOUR = "#d6e4fa"  # a pale version of the viewer's idle blue
STATE_LABELS = {timeline.FAILED: "down"}
PLOT_FILES = ("tasks.png", "battery.png", "allocation.png", "robots.png")
# task kinds in a fixed order of colours (tab10 without the state colours' look-alikes)
KIND_COLOURS = ("#1f77b4", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#d62728",
                "#2ca02c", "#ff7f0e", "#7f7f7f")
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
    series["allocated"] = list(first_awards(evs).values())
    for e in evs:
        k = e["kind"]
        if k == ev.TASK_INTRODUCED:
            series["introduced"].append(float(e["t"]))
        elif k == ev.TASK_OUTCOME:
            series[ev.counted_outcome(e)].append(float(e["t"]))
    fig, ax = plt.subplots(figsize=(9, 4.5), dpi=100)
    for name in ("introduced", "allocated", *ev.COUNTED_OUTCOMES):
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


def _value_at(xs: list[float], ys: list[float], x: float) -> float | None:
    """The last sample at or before x (the first one if x comes earlier)."""
    if not xs:
        return None
    best = ys[0]
    for xv, yv in zip(xs, ys, strict=True):
        if xv > x:
            break
        best = yv
    return best


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
    charging = [iv for ivs in timeline.robot_intervals(evs, end_s=end_s).values() for iv in ivs
                if iv.state == timeline.CHARGING]
    for k, iv in enumerate(charging):
        ax.axvspan(iv.start_s / scale, max(iv.end_s, iv.start_s + end_s * 0.002) / scale,
                   color=STATE_COLOURS[timeline.CHARGING], alpha=0.22, linewidth=0,
                   label="charging" if k == 0 else None)
        xs, ys = series.get(iv.robot, ([], []))
        y = _value_at(xs, ys, iv.start_s / scale)
        if y is not None:
            ax.plot([iv.start_s / scale], [y], marker="v", markersize=7,
                    color=STATE_COLOURS[timeline.CHARGING], markeredgecolor="black",
                    markeredgewidth=0.6, linestyle="none")
    ax.set_ylim(0, 105)
    ax.set_xlim(0, max(end_s / scale, 1e-6))
    ax.set_xlabel(_time_axis(ax, end_s))
    ax.set_ylabel("battery (%)")
    trips = f"{len(charging)} charging trip{'s' if len(charging) != 1 else ''}"
    ax.set_title(f"Battery of every robot ({trips}: green bands, ▼ where each began)")
    ax.grid(True, alpha=0.3)
    if series:
        ax.legend(loc="lower left", ncol=min(7, len(series) + 1), fontsize="small")
    fig.tight_layout()
    return fig


def _short_label(label: str) -> str:
    """The task kind of a "<kind> <task id>" label."""
    return label.split(" ", 1)[0]


def _fits(text: str, width_px: float, fontsize: float, dpi: float) -> bool:
    return len(text) * fontsize * 0.62 * dpi / 72.0 + 4.0 <= width_px


def plot_allocation(
    evs: list[Mapping[str, Any]], end_s: float, robots: Iterable[str] = ()
) -> Figure:
    scale = _scale(end_s)
    intervals = timeline.robot_intervals(evs, robots, end_s=end_s)
    names = sorted(intervals)
    dpi = 100
    fig, ax = plt.subplots(figsize=(11, 1.3 + 0.55 * max(1, len(names))), dpi=dpi)
    span = end_s / scale
    fig.tight_layout()
    axes_px = ax.get_window_extent().width
    seen: set[str] = set()
    fontsize = 7.0
    for row, name in enumerate(names):
        for iv in intervals[name]:
            colour = STATE_COLOURS.get(iv.state)
            if colour is None:
                continue
            seen.add(iv.state)
            x0, w = iv.start_s / scale, (iv.end_s - iv.start_s) / scale
            ax.broken_barh([(x0, w)], (row - 0.38, 0.76), facecolors=colour,
                           edgecolors="white", linewidth=0.5)
            if iv.state != timeline.WORKING or span <= 0:
                continue
            width_px = w / span * axes_px
            # the whole label, else the task kind, else its first word, else nothing: labels
            # never overlap
            kind = _short_label(iv.label)
            for text in (iv.label, kind, kind.split("-", 1)[0]):
                if _fits(text, width_px, fontsize, dpi):
                    ax.text(x0 + w / 2, row, text, ha="center", va="center",
                            fontsize=fontsize, clip_on=True)
                    break
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names)
    ax.set_ylim(-0.6, len(names) - 0.4)
    ax.set_xlim(0, max(span, 1e-6))
    ax.invert_yaxis()
    ax.set_xlabel(_time_axis(ax, end_s))
    ax.set_title("Allocation timeline per robot (blank: idle)", loc="left")
    handles = [Patch(color=c, label=STATE_LABELS.get(st, st))
               for st, c in STATE_COLOURS.items() if st in seen]
    if handles:
        ax.legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0),
                  fontsize="small", ncol=len(handles), frameon=False)
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def robot_shares(
    evs: list[Mapping[str, Any]], end_s: float, robots: Iterable[str] = ()
) -> dict[str, dict[str, float]]:
    """Each robot's share of the run (0-1) in each state: idle, working, charging, failed."""
    shares: dict[str, dict[str, float]] = {}
    for name, ivs in timeline.robot_intervals(evs, robots, end_s=end_s).items():
        total = {st: 0.0 for st in timeline.STATES}
        for iv in ivs:
            total[iv.state] += iv.end_s - iv.start_s
        whole = sum(total.values())
        shares[name] = {st: (v / whole if whole > 0 else 0.0) for st, v in total.items()}
    return shares


def tasks_by_kind(evs: list[Mapping[str, Any]]) -> dict[str, dict[str, int]]:
    """How many tasks of each kind each robot was awarded (a task awarded again after a
    reallocation counts for each robot that held it)."""
    kind_of: dict[str, str] = {}
    counts: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    held: set[tuple[str, str]] = set()
    for e in evs:
        if e["kind"] == ev.TASK_INTRODUCED:
            kind_of[str(e["task"])] = str(e["task_kind"])
        elif e["kind"] == ev.AWARD:
            key = (str(e["robot"]), str(e["task"]))
            if key not in held:
                held.add(key)
                counts[key[0]][kind_of.get(key[1], str(e.get("task_kind", "other")))] += 1
    return {r: dict(c) for r, c in counts.items()}


def plot_robots(
    evs: list[Mapping[str, Any]], end_s: float, robots: Iterable[str] = ()
) -> Figure:
    shares = robot_shares(evs, end_s, robots)
    kinds_per_robot = tasks_by_kind(evs)
    names = sorted(set(shares) | set(kinds_per_robot))
    kinds = sorted({k for c in kinds_per_robot.values() for k in c})
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 1.6 + 0.5 * max(1, len(names))),
                                      dpi=100, sharey=True)
    ys = range(len(names))
    base = [0.0] * len(names)
    for k, kind in enumerate(kinds):
        counts = [kinds_per_robot.get(n, {}).get(kind, 0) for n in names]
        left.barh(ys, counts, left=base, color=KIND_COLOURS[k % len(KIND_COLOURS)],
                  label=kind, height=0.7)
        for y, (b, c) in enumerate(zip(base, counts, strict=True)):
            if c:
                left.text(b + c / 2, y, str(c), ha="center", va="center", fontsize=7,
                          color="white")
        base = [b + c for b, c in zip(base, counts, strict=True)]
    left.set_yticks(list(ys))
    left.set_yticklabels(names)
    left.invert_yaxis()
    left.xaxis.set_major_locator(MaxNLocator(integer=True))
    left.set_xlabel("tasks won")
    left.set_title("Tasks won", loc="left")
    if kinds:
        left.legend(fontsize="small", loc="lower right", bbox_to_anchor=(1.0, 1.0),
                    ncol=min(3, len(kinds)), frameon=False)
    left.grid(True, axis="x", alpha=0.3)
    colours = {timeline.IDLE: IDLE_COLOUR, **STATE_COLOURS}
    base = [0.0] * len(names)
    for st in timeline.STATES:
        values = [100.0 * shares.get(n, {}).get(st, 0.0) for n in names]
        if not any(values):
            continue  # the legend lists only the states that occur
        right.barh(ys, values, left=base, color=colours[st], height=0.7,
                   label=STATE_LABELS.get(st, st), edgecolor="white", linewidth=0.5)
        for y, (b, v) in enumerate(zip(base, values, strict=True)):
            if v >= 7:
                right.text(b + v / 2, y, f"{v:.0f}%", ha="center", va="center", fontsize=7)
        base = [b + v for b, v in zip(base, values, strict=True)]
    right.set_xlim(0, 100)
    right.set_xlabel("share of the run (%)")
    right.set_title("Share of time", loc="left")
    if right.get_legend_handles_labels()[0]:
        right.legend(fontsize="small", loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=4,
                     frameon=False)
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


def save(fig: Figure, path: Path) -> Path:
    """Write `fig` to `path` and free it."""
    fig.savefig(path)
    plt.close(fig)
    return path


def write_plots(
    evs: Iterable[Mapping[str, Any]], out_dir: Path, robots: Iterable[str] = (),
    plugin: Experiment | None = None,
) -> list[Path]:
    """Write the PNGs of `PLOT_FILES`, then those of the run's experiment `plugin`, into
    `out_dir`; returns their paths."""
    evs = [e for e in evs if e["kind"] != ev.POSES]
    end_s = max((float(e["t"]) for e in evs), default=0.0)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for filename, fig in zip(
        PLOT_FILES,
        (plot_tasks(evs, end_s), plot_battery(evs, end_s),
         plot_allocation(evs, end_s, robots), plot_robots(evs, end_s, robots)),
        strict=True,
    ):
        paths.append(save(fig, out_dir / filename))
    if plugin is not None:
        paths += plugin.plots(evs, out_dir)
    return paths
