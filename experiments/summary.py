"""A run's counts, as the MURDOCH paper reports them, computed from its events alone.

`summarize(events)` returns a JSON-ready dict; `murdoch report` writes it to summary.json.
`terminal_state_problems(events)` lists tasks that did not end in exactly one of completed /
failed / unachievable / open at the end (the run's central invariant). A task the run's end
cut short counts as ``open_at_end``, not as failed (`events.counted_outcome`).
"""

from __future__ import annotations

import statistics
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from experiments import events as ev

if TYPE_CHECKING:
    from experiments.plugin import Experiment

SCHEMA_VERSION = 1


def _latency_stats(values: list[float]) -> dict[str, float | int | None]:
    if not values:
        return {"count": 0, "mean": None, "median": None, "p95": None, "max": None}
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return {
        "count": len(ordered),
        "mean": round(statistics.fmean(ordered), 6),
        "median": round(statistics.median(ordered), 6),
        "p95": round(p95, 6),
        "max": round(ordered[-1], 6),
    }


def terminal_state_problems(events: Iterable[Mapping[str, Any]]) -> dict[str, list[str]]:
    """Tasks with no terminal outcome, with more than one, or with an outcome but never
    introduced. Empty lists everywhere mean the invariant holds."""
    introduced: set[str] = set()
    outcomes: dict[str, list[str]] = defaultdict(list)
    for e in events:
        if e["kind"] == ev.TASK_INTRODUCED:
            introduced.add(str(e["task"]))
        elif e["kind"] == ev.TASK_OUTCOME:
            outcomes[str(e["task"])].append(str(e["outcome"]))
    return {
        "without_outcome": sorted(introduced - outcomes.keys()),
        "several_outcomes": sorted(t for t, o in outcomes.items() if len(o) > 1),
        "never_introduced": sorted(outcomes.keys() - introduced),
    }


def charging_cycles(events: Iterable[Mapping[str, Any]]) -> tuple[int, dict[str, int]]:
    """Completed charge cycles, in all and per robot: a `charge_start` followed by its
    `charge_end`. Further starts before the end belong to the same cycle (a robot that
    re-docks), and a cycle cut off by the robot's failure or by the end of the run is not
    counted."""
    charging: set[str] = set()
    per_robot: Counter[str] = Counter()
    for e in events:
        kind = e["kind"]
        if kind == ev.CHARGE_START:
            charging.add(str(e["robot"]))
        elif kind == ev.CHARGE_END and str(e["robot"]) in charging:
            charging.discard(str(e["robot"]))
            per_robot[str(e["robot"])] += 1
        elif kind == ev.ROBOT_FAILURE:
            charging.discard(str(e["robot"]))
    return sum(per_robot.values()), dict(sorted(per_robot.items()))


def _user_task(e: Mapping[str, Any]) -> bool:
    return e.get("source") in (None, "user")


def allocation_attempts(events: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """The paper's "error returned" apart from the end of the user's patience.

    `first_attempt_unallocatable`: tasks whose first auction closed without a bid;
    `then_allocated`: those of them a later round (after backoff) gave to a robot;
    `unachievable_after_backoff`: tasks that ended unachievable (no bid until the deadline).
    Counted over the user's tasks (sub-tasks that robots announced are in `subtasks`)."""
    user: set[str] = set()
    sub: set[str] = set()
    first_no_bid: set[str] = set()
    awarded: set[str] = set()
    unachievable: set[str] = set()
    for e in events:
        kind = e["kind"]
        if kind == ev.TASK_INTRODUCED:
            (user if _user_task(e) else sub).add(str(e["task"]))
        elif kind == ev.NO_BID and int(e["attempt"]) == 1:
            first_no_bid.add(str(e["task"]))
        elif kind == ev.AWARD:
            awarded.add(str(e["task"]))
        elif kind == ev.TASK_OUTCOME and e["outcome"] == ev.UNACHIEVABLE:
            unachievable.add(str(e["task"]))

    def counts(tasks: set[str]) -> dict[str, int]:
        first = first_no_bid & tasks
        return {"first_attempt_unallocatable": len(first),
                "then_allocated": len(first & awarded),
                "unachievable_after_backoff": len(unachievable & tasks)}

    return {**counts(user), "subtasks": counts(sub)}


def waits(events: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """Introduction of each user task to its first award (when its robot starts on it);
    group tasks, which are never awarded whole, are in `group_tasks`."""
    introduced: dict[str, float] = {}
    values: list[float] = []
    for e in events:
        if e["kind"] == ev.TASK_INTRODUCED and _user_task(e) and not e.get("group"):
            introduced.setdefault(str(e["task"]), float(e["t"]))
        elif e["kind"] == ev.AWARD and str(e["task"]) in introduced:
            values.append(float(e["t"]) - introduced.pop(str(e["task"])))
    return {**_latency_stats(values), "never_awarded": len(introduced)}


def memory_by_process(records: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per process: its pid, first, last and peak resident memory and how often sampled
    (and, for a process running several robots, how many and its peak per robot)."""
    processes: dict[str, dict[str, Any]] = {}
    for e in records:
        if e["kind"] == ev.PROCESS:
            name = str(e["name"])
            rss = int(e["rss_bytes"])
            peak = int(e.get("peak_rss_bytes", rss))
            p = processes.setdefault(
                name, {"pid": e["pid"], "rss_first_bytes": rss, "peak_rss_bytes": 0}
            )
            p["rss_last_bytes"] = rss
            p["peak_rss_bytes"] = max(p["peak_rss_bytes"], peak, rss)
            p["samples"] = p.get("samples", 0) + 1
            if "robots" in e:  # a process running several robots
                p["robots"] = int(e["robots"])
                p["peak_rss_per_robot_bytes"] = p["peak_rss_bytes"] // max(p["robots"], 1)
    return processes


def lowest_battery(events: Iterable[Mapping[str, Any]]) -> float | None:
    """The lowest battery level any robot reported (None: no reports)."""
    battery_min: float | None = None
    for e in events:
        if e["kind"] == ev.BATTERY and e["percent"]:
            low = min(float(v) for v in e["percent"].values())
            battery_min = low if battery_min is None else min(battery_min, low)
    return battery_min


def messages_by_kind(events: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, int]]:
    """Messages and bytes heard, by message kind."""
    messages: dict[str, dict[str, int]] = {}
    for e in events:
        if e["kind"] == ev.MESSAGE:
            m = messages.setdefault(str(e["msg_kind"]), {"count": 0, "bytes": 0})
            m["count"] += 1
            m["bytes"] += int(e["bytes"])
    return messages


def first_awards(events: Iterable[Mapping[str, Any]]) -> dict[str, float]:
    """When each allocated task was first awarded (task -> simulated time, in award order)."""
    first: dict[str, float] = {}
    for e in events:
        if e["kind"] == ev.AWARD:
            first.setdefault(str(e["task"]), float(e["t"]))
    return first


def auction_latencies(events: Iterable[Mapping[str, Any]]) -> list[float]:
    """Each award's latency: its own figure, else the task's first announcement to it."""
    first_announce: dict[str, float] = {}
    latencies: list[float] = []
    for e in events:
        if e["kind"] == ev.MESSAGE and e.get("msg_kind") == "announce" and "task" in e:
            first_announce.setdefault(str(e["task"]), float(e["t"]))
        elif e["kind"] == ev.AWARD:
            if "latency_s" in e:
                latencies.append(float(e["latency_s"]))
            elif str(e["task"]) in first_announce:
                latencies.append(float(e["t"]) - first_announce[str(e["task"])])
    return latencies


def summarize(events: Iterable[Mapping[str, Any]],
              process_records: Iterable[Mapping[str, Any]] = (),
              plugin: Experiment | None = None) -> dict[str, Any]:
    """The summary of a run from its events (simulated history) and its processes.jsonl
    records (wall-clock facts: memory samples and the wall time), with the sections of the
    run's experiment `plugin` (boxpush: "goal")."""
    evs = list(events)
    wall_records = list(process_records)
    kinds = Counter(str(e["kind"]) for e in evs)
    outcomes = Counter(ev.counted_outcome(e) for e in evs if e["kind"] == ev.TASK_OUTCOME)
    task_kind_of: dict[str, str] = {}
    for e in evs:
        if e["kind"] == ev.TASK_INTRODUCED:
            task_kind_of[str(e["task"])] = str(e["task_kind"])

    messages = messages_by_kind(evs)
    latencies = auction_latencies(evs)

    # per robot
    per_robot: dict[str, Counter[str]] = defaultdict(Counter)
    for e in evs:
        k = e["kind"]
        if k == ev.AWARD:
            per_robot[str(e["robot"])]["awards"] += 1
        elif k == ev.TASK_OUTCOME and e.get("robot") and e["outcome"] == ev.COMPLETED:
            per_robot[str(e["robot"])]["tasks_completed"] += 1
        elif k == ev.ROBOT_FAILURE:
            per_robot[str(e["robot"])]["failures"] += 1

    by_task_kind: dict[str, Counter[str]] = defaultdict(Counter)
    for e in evs:
        if e["kind"] == ev.TASK_INTRODUCED:
            by_task_kind[str(e["task_kind"])]["introduced"] += 1
        elif e["kind"] == ev.TASK_OUTCOME:
            by_task_kind[task_kind_of.get(str(e["task"]), "unknown")][ev.counted_outcome(e)] += 1

    processes = memory_by_process([*evs, *wall_records])
    sim_s = max((float(e["t"]) for e in evs), default=0.0)
    run_end = next((e for e in reversed(evs) if e["kind"] == ev.RUN_END), None)
    run_start = next((e for e in evs if e["kind"] == ev.RUN_START), None)
    run_wall = next((e for e in reversed(wall_records) if e["kind"] == ev.RUN_WALL), None)
    wall_s: float | None = None
    if run_wall is not None:
        wall_s = float(run_wall["wall_s"])
    elif run_end is not None and "wall_s" in run_end:  # runs recorded before processes.jsonl
        wall_s = float(run_end["wall_s"])
    battery_min = lowest_battery(evs)

    trips, trips_per_robot = charging_cycles(evs)
    for robot, n in trips_per_robot.items():
        per_robot[robot]["charging_trips"] = n
    problems = terminal_state_problems(evs)
    sections = plugin.summary_sections(evs) if plugin is not None else {}
    summary = {
        "schema": SCHEMA_VERSION,
        "experiment": run_start.get("experiment") if run_start else None,
        "seed": run_start.get("seed") if run_start else None,
        "end_reason": run_end.get("reason") if run_end else None,
        "sim_time_s": round(sim_s, 3),
        "wall_time_s": round(wall_s, 3) if wall_s is not None else None,
        "real_time_factor": round(sim_s / wall_s, 3) if wall_s else None,
        "tasks": {
            "introduced": kinds[ev.TASK_INTRODUCED],
            "allocated": len(first_awards(evs)),
            "executed": outcomes[ev.COMPLETED],
            "failed": outcomes[ev.FAILED],
            "unachievable": outcomes[ev.UNACHIEVABLE],
            "open_at_end": outcomes[ev.OPEN_AT_END],
            "reallocations": kinds[ev.REALLOCATION],
            **allocation_attempts(evs),
            "by_kind": {k: dict(sorted(v.items())) for k, v in sorted(by_task_kind.items())},
        },
        "bids": {"declined": kinds[ev.BID_DECLINED], "expired": kinds[ev.BID_EXPIRED]},
        "charging_trips": trips,
        "charging_starts": kinds[ev.CHARGE_START],
        "robot_failures": kinds[ev.ROBOT_FAILURE],
        "robot_restarts": kinds[ev.ROBOT_RESTART],
        "alarms": kinds[ev.ALARM],
        "goal": None,
        "lowest_battery_percent": battery_min,
        "messages": {
            "by_kind": dict(sorted(messages.items())),
            "total": sum(m["count"] for m in messages.values()),
            "total_bytes": sum(m["bytes"] for m in messages.values()),
        },
        "auction_latency_s": _latency_stats(latencies),
        "waits_s": waits(evs),
        "robots": {r: dict(sorted(c.items())) for r, c in sorted(per_robot.items())},
        "processes": dict(sorted(processes.items())),
        "invariant_terminal_states": {
            "holds": not any(problems.values()),
            **{k: v[:50] for k, v in problems.items()},
        },
        "event_counts": dict(sorted(kinds.items())),
    }
    summary.update(sections)
    return summary
