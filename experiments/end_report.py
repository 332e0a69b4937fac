"""The block printed when a run ends (and by `murdoch report`): what happened, where the
files are, and what to try next. Pure: lists of lines from a summary and paths."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from experiments.progress import hms


def summary_lines(s: Mapping[str, Any]) -> list[str]:
    """The summary's headline figures, one labelled line each."""
    tasks = s["tasks"]
    rtf = s.get("real_time_factor")
    wall = s.get("wall_time_s")
    lines = [
        f"sim time   {hms(float(s['sim_time_s']))} simulated"
        + (f" in {hms(float(wall))} wall, real-time factor {rtf}" if wall is not None else ""),
        f"tasks      introduced {tasks['introduced']}  executed {tasks['executed']}  "
        f"failed {tasks['failed']}  unachievable {tasks['unachievable']}  "
        f"open at end {tasks.get('open_at_end', 0)}  reallocations {tasks['reallocations']}",
        f"charging   {s['charging_trips']} completed trips"
        + (f" ({s['charging_starts']} charge starts)" if "charging_starts" in s else "")
        + f"   robot failures {s['robot_failures']}   restarts {s.get('robot_restarts', 0)}",
        f"messages   {s['messages']['total']} ({s['messages']['total_bytes']} bytes)",
    ]
    if "first_attempt_unallocatable" in tasks:
        lines.insert(2, f"no bid     first auction of {tasks['first_attempt_unallocatable']} "
                        f"task(s) (allocated after backoff {tasks['then_allocated']}, "
                        f"unachievable after backoff {tasks['unachievable_after_backoff']})")
    waits = s.get("waits_s") or {}
    if waits.get("count"):
        lines.insert(3, f"waits      introduction to award: median {waits['median']:g} s, "
                        f"p95 {waits['p95']:g} s, max {waits['max']:g} s")
    goal = s.get("goal")
    if goal:
        if goal.get("reached"):
            lines.append(f"goal       reached at {goal['reached_t_s']} s "
                         f"(box {goal['box_distance_m']} m from the goal)")
        elif goal.get("unachievable"):
            lines.append(f"goal       unachievable: {goal.get('unachievable_reason')}")
        else:
            lines.append("goal       not reached")
        swap = (goal.get("pushes") or {}).get("role_swap")
        if swap is not None:
            lines.append(f"role swap  {swap['robot']}: {swap['end_before']} end before, "
                         f"{swap['end_after']} end after: {'yes' if swap['swapped'] else 'NO'}")
    group = s.get("group_tasks")
    if group and group.get("introduced"):
        lines.append(f"groups     introduced {group['introduced']}  completed "
                     f"{group['completed']}  failed {group['failed']}  unachievable "
                     f"{group['unachievable']}  open at end {group['open_at_end']}"
                     + (f"  (in place {group['in_place_mean_s']:g} s after introduction, "
                        "mean)" if group.get("in_place_mean_s") is not None else ""))
    if s.get("allocator") not in (None, "murdoch"):
        lines.insert(0, f"allocator  {s['allocator']}")
    inv = s["invariant_terminal_states"]
    lines.append("invariant  every task ends in exactly one terminal state: "
                 f"{'yes' if inv['holds'] else 'NO'}")
    return lines


def next_steps(experiment: str, run_root: Path) -> list[str]:
    """Commands worth trying after a run of `experiment` (its plug-in's, else longterm's)."""
    from experiments.registry import experiments

    every = experiments()
    plugin = every.get(experiment, every["longterm"])
    return [f"murdoch report {run_root}            # rebuild summary and plots",
            *plugin.next_steps(),
            "murdoch allocate consensus-small       # CBBA on a bundled scenario"]


def end_of_run_lines(
    *,
    experiment: str,
    reason: str,
    run_root: Path,
    summary: Mapping[str, Any],
    plots: Sequence[Path],
    replay: Path | None,
    problems: Sequence[str] = (),
) -> list[str]:
    """The whole block: a headline (``interrupted`` on Ctrl-C), the summary, the files, the
    problems met writing them, and what to try next."""
    sim = hms(float(summary["sim_time_s"]))
    if reason == "interrupted":
        head = f"interrupted at {sim} simulated; what was recorded so far:"
    elif reason == "completed":
        head = f"{experiment} finished: {sim} simulated"
    else:
        head = f"{experiment} stopped ({reason}) at {sim} simulated"
    lines = [head, *("  " + line for line in summary_lines(summary)), "files"]
    root = Path(run_root)
    lines.append(f"  run directory  {root}")
    lines.append(f"  summary        {root / 'summary.json'}")
    if replay is not None:
        lines.append(f"  replay         {replay}   (open it in a browser)")
    for p in plots:
        lines.append(f"  plot           {p}")
    if not plots:
        lines.append(f"  plots          none drawn (murdoch report {root} draws them)")
    lines.append(f"  events         {root / 'events.jsonl'}   (what simulation time decided)")
    if (root / "run.mcap").is_file():
        lines.append(f"  recording      {root / 'run.mcap'}   (open it in Foxglove; "
                     f"murdoch record-info {root})")
    lines.append(f"  logs           {root / 'logs'}")
    for problem in problems:
        lines.append(f"error: {problem}")
    lines.append("next")
    lines.extend(f"  {step}" for step in next_steps(experiment, root))
    return lines
