"""The soak report of a run directory: `soak.json`, `soak.md` and `plots/soak-*.png`.

Everything comes from the run's files: events.jsonl (simulation-time facts), processes.jsonl
(memory samples), run.mcap (the odometry of the dead-controller check) and config.json (the
fault schedule and the limits), so `murdoch soak-report RUN_DIR` rebuilds it.
"""

from __future__ import annotations

import json
import statistics
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from experiments import events as ev
from experiments.rundir import open_run_dir
from experiments.soak.invariants import (
    Limits,
    Verdict,
    check_dead_controllers,
    check_events,
    dead_spans,
    memory_slopes,
    slope_per_hour,
)

SOAK_JSON = "soak.json"
SOAK_MD = "soak.md"
PLOT_FILES = ("soak-tasks.png", "soak-reallocation.png", "soak-auction-latency.png",
              "soak-memory.png", "soak-messages.png", "soak-faults.png")
FAULT_KINDS = (ev.ROBOT_FAILURE, ev.ROBOT_RESTART, ev.ROBOT_FREEZE, ev.ROBOT_THAW,
               ev.ROBOT_SWITCH_OFF, ev.CHARGER_OFF, ev.CHARGER_ON, ev.TASK_BURST,
               ev.FAULT_SKIPPED)


def _stats(values: list[float]) -> dict[str, Any]:
    if not values:
        return {"count": 0}
    s = sorted(values)
    return {"count": len(s), "min": round(s[0], 3), "median": round(statistics.median(s), 3),
            "p95": round(s[min(len(s) - 1, int(0.95 * len(s)))], 3), "max": round(s[-1], 3),
            "mean": round(statistics.fmean(s), 3)}


def _drive(recording: Path, robots: list[str],
           seen: list[str]) -> Iterator[tuple[str, float, float, float]]:
    """Each odometry sample's drive command (`cmd_vx`, `cmd_vyaw`); a recording from before
    commands were recorded gives the measured velocity instead. `seen` collects which."""
    from player_server.record.reader import iter_messages

    topics = [f"/{r}/odometry" for r in robots]
    for rec in iter_messages(recording, topics):
        d = rec.json()
        if "cmd_vx" in d:
            kind, vx, vyaw = "drive commands", d["cmd_vx"], d.get("cmd_vyaw", 0.0)
        else:
            kind, vx, vyaw = "odometry samples", d.get("vx", 0.0), d.get("vyaw", 0.0)
        if kind not in seen:
            seen.append(kind)
        yield rec.topic.split("/")[1], rec.t_s, float(vx), float(vyaw)


def build_report(run_dir: Path, *, plots: bool = True) -> dict[str, Any]:
    run = open_run_dir(run_dir)
    config = run.read_config()
    soak_cfg = config.get("soak") or {}
    limits = Limits(**soak_cfg["limits"]) if soak_cfg.get("limits") else Limits.defaults()
    events = ev.read_events(run.events)
    end_t = max((float(e["t"]) for e in events), default=0.0)
    hours = max(1, int(-(-end_t // 3600)))
    inv = check_events(events, limits, end_t)
    verdicts: dict[str, Verdict] = dict(inv.verdicts)
    # dead controllers, from the recorded odometry
    spans = dead_spans(events, end_t)
    if run.recording.exists():
        seen: list[str] = []
        samples_iter = list(_drive(run.recording, sorted(spans), seen))
        verdicts["dead_controller_still"] = check_dead_controllers(
            spans, samples_iter, " and ".join(seen) or "drive commands")
    else:
        v = Verdict("dead_controller_still", "no robot drives with a dead controller",
                    checked=False, note="no run.mcap (run with --no-record)")
        verdicts["dead_controller_still"] = v
    samples = list(ev.iter_events(run.processes)) if run.processes.exists() else []
    mem_verdict, mem = memory_slopes(samples, end_t, limits.memory_slope_mib_per_h)
    verdicts["memory_flat"] = mem_verdict

    per_hour: dict[str, list[int]] = {k: [0] * hours for k in (
        "introduced", "completed", "failed", "unachievable", "messages", "bytes")}
    latency_by_hour: list[list[float]] = [[] for _ in range(hours)]
    msg_kinds: Counter[str] = Counter()
    faults: list[dict[str, Any]] = []
    fault_counts: Counter[str] = Counter()
    for e in events:
        kind, t = e["kind"], float(e["t"])
        h = min(hours - 1, int(t // 3600))
        if kind == ev.TASK_INTRODUCED:
            per_hour["introduced"][h] += 1
        elif kind == ev.TASK_OUTCOME and e["outcome"] in ev.OUTCOMES:
            per_hour[str(e["outcome"])][h] += 1
        elif kind == ev.MESSAGE:
            per_hour["messages"][h] += 1
            per_hour["bytes"][h] += int(e.get("bytes", 0))
            msg_kinds[str(e.get("msg_kind"))] += 1
        elif kind == ev.AWARD and isinstance(e.get("latency_s"), int | float):
            latency_by_hour[h].append(float(e["latency_s"]))
        if kind in FAULT_KINDS:
            label = kind if kind != ev.ROBOT_FAILURE else f"{kind}:{e.get('reason', '')}"
            fault_counts[label] += 1
            faults.append({k: v for k, v in e.items() if k != "tasks"})
    auction = [{"hour": i, **_stats(v)} for i, v in enumerate(latency_by_hour)]
    medians = [(i * 3600.0, a["median"]) for i, a in enumerate(auction) if a["count"]]
    drift = round(slope_per_hour(medians), 4) if len(medians) >= 2 else None
    realloc = [r for r in inv.realloc_latencies if r["latency_s"] is not None]
    effects = _fault_effects(faults, inv.realloc_latencies)
    config_faults = config.get("faults", [])
    report: dict[str, Any] = {
        "run_dir": str(run.root),
        "experiment": config.get("experiment"),
        "seed": config.get("seed"),
        "sim_hours": round(end_t / 3600.0, 3),
        "limits": limits.as_dict(),
        "all_held": all(v.held for v in verdicts.values()),
        "invariants": {k: v.as_dict() for k, v in verdicts.items()},
        "tasks_per_hour": {k: per_hour[k] for k in ("introduced", "completed", "failed",
                                                     "unachievable")},
        "tasks_total": {k: sum(per_hour[k]) for k in ("introduced", "completed", "failed",
                                                      "unachievable")},
        "reallocation_latency_s": {**_stats([r["latency_s"] for r in realloc]),
                                   "samples": inv.realloc_latencies},
        "auction_latency_per_hour": auction,
        "auction_latency_drift_s_per_h": drift,
        "memory": mem,
        "messages_per_hour": per_hour["messages"],
        "bytes_per_hour": per_hour["bytes"],
        "messages_by_kind": dict(sorted(msg_kinds.items())),
        "faults_scheduled": len(config_faults),
        "faults_injected": dict(sorted(fault_counts.items())),
        "fault_effects": effects,
        "wall_time_s": _run_wall(samples).get("wall_s"),
        "bus_loss": {**(soak_cfg.get("bus_loss") or {}),
                     **(_run_wall(samples).get("bus_loss_runner") or {})} or None,
    }
    (run.root / SOAK_JSON).write_text(json.dumps(report, indent=2) + "\n")
    (run.root / SOAK_MD).write_text(markdown(report))
    if plots:
        _plots(run.plots, report, samples, faults, end_t)
    return report


def _run_wall(samples: Iterable[Mapping[str, Any]]) -> Mapping[str, Any]:
    for s in samples:
        if s.get("kind") == ev.RUN_WALL:
            return s
    return {}


def _fault_effects(faults: list[dict[str, Any]], latencies: list[dict[str, Any]]
                   ) -> list[dict[str, Any]]:
    """Each fault, with the tasks it took from a holder and what became of them."""
    by_fault: dict[tuple[str, str, float], list[dict[str, Any]]] = defaultdict(list)
    for r in latencies:
        by_fault[(r["robot"], r["cause"], r["fault_t"])].append(r)
    out = []
    for f in faults:
        entry = dict(f)
        cause = {ev.ROBOT_FAILURE: f.get("reason"), ev.ROBOT_FREEZE: "frozen",
                 ev.ROBOT_SWITCH_OFF: "switched-off"}.get(f["kind"])
        if cause is not None:
            entry["tasks_taken"] = [
                {k: r[k] for k in ("task", "latency_s", "how")}
                for r in by_fault.get((str(f.get("robot")), str(cause), float(f["t"])), [])]
        out.append(entry)
    return out


def markdown(r: Mapping[str, Any]) -> str:
    lines = [f"# Soak report: {r['experiment']}, seed {r['seed']}, "
             f"{r['sim_hours']:g} simulated hours", ""]
    lines.append("All invariants held." if r["all_held"] else "**An invariant broke.**")
    lines += ["", "## Invariants", "", "| invariant | verdict | first counter-example |",
              "|---|---|---|"]
    for name, v in r["invariants"].items():
        verdict = ("held" if v["held"] else f"BROKEN ({v['breaches']}x)") if v["checked"] \
            else "not checked"
        example = json.dumps(v["first_counter_example"]) if v["first_counter_example"] else \
            (v.get("note") or "")
        lines.append(f"| {name}: {v['description']} | {verdict} | {example} |")
    t = r["tasks_total"]
    lines += ["", "## Tasks", "",
              f"introduced {t['introduced']}, completed {t['completed']}, failed "
              f"{t['failed']}, unachievable {t['unachievable']}", "",
              "| hour | introduced | completed | failed | unachievable |", "|---|---|---|---|---|"]
    tp = r["tasks_per_hour"]
    for h in range(len(tp["introduced"])):
        lines.append(f"| {h} | {tp['introduced'][h]} | {tp['completed'][h]} | "
                     f"{tp['failed'][h]} | {tp['unachievable'][h]} |")
    rl = r["reallocation_latency_s"]
    lines += ["", "## Reallocation after a holder's fault (simulated s)", "",
              f"bound {r['limits']['realloc_bound_s']} s; " + ", ".join(
                  f"{k} {v}" for k, v in rl.items() if k != "samples"), "",
              "## Auction latency per hour (announce to award, simulated s)", "",
              f"drift of the hourly median: {r['auction_latency_drift_s_per_h']} s per hour",
              "", "| hour | awards | median | p95 | max |", "|---|---|---|---|---|"]
    for a in r["auction_latency_per_hour"]:
        lines.append(f"| {a['hour']} | {a['count']} | {a.get('median', '')} | "
                     f"{a.get('p95', '')} | {a.get('max', '')} |")
    lines += ["", "## Memory (second half of the run)", "",
              f"limit {r['limits']['memory_slope_mib_per_h']} MiB per simulated hour (a "
              "host process's slope is per robot)", "",
              "| process | samples | slope MiB/h | first MiB | last MiB |", "|---|---|---|---|---|"]
    for name, m in r["memory"].items():
        shared = f" ({m['robots']} robots)" if "robots" in m else ""
        lines.append(f"| {name}{shared} | {m['samples']} | {m['slope_mib_per_h']} | "
                     f"{m.get('first_mib', '')} | {m.get('last_mib', '')} |")
    lines += ["", "## Messages per hour", "", "| hour | messages | bytes |", "|---|---|---|"]
    for h, (n, b) in enumerate(zip(r["messages_per_hour"], r["bytes_per_hour"], strict=True)):
        lines.append(f"| {h} | {n} | {b} |")
    lines += ["", "## Faults", "", f"scheduled {r['faults_scheduled']}; injected: "
              + ", ".join(f"{k} {v}" for k, v in r["faults_injected"].items()), "",
              "| t (s) | fault | target | effect |", "|---|---|---|---|"]
    for f in r["fault_effects"]:
        target = f.get("robot") or f.get("charger") or f.get("count", "")
        effect = ""
        if f["kind"] == ev.FAULT_SKIPPED:
            effect = f"skipped ({f.get('action')}): {f.get('reason')}"
        elif f.get("tasks_taken"):
            effect = "; ".join(f"{x['task']}: {x.get('how', 'unresolved')} after "
                               f"{x['latency_s']} s" for x in f["tasks_taken"])
        elif "tasks_taken" in f:
            effect = "held no task"
        lines.append(f"| {f['t']:.1f} | {f['kind']} {f.get('reason', '')} | {target} | "
                     f"{effect} |")
    if r.get("bus_loss"):
        lines += ["", f"Loss on the bus (the runner's receiver): {json.dumps(r['bus_loss'])}"]
    lines += ["", f"Wall time: {r.get('wall_time_s')} s"]
    lines += ["", "Plots: " + ", ".join(f"plots/{p}" for p in PLOT_FILES), ""]
    return "\n".join(lines)


def print_report(r: Mapping[str, Any], echo: Callable[[str], None]) -> None:
    echo(f"soak report ({r['sim_hours']:g} simulated hours): {r['run_dir']}/{SOAK_MD}")
    for name, v in r["invariants"].items():
        verdict = ("held" if v["held"] else "BROKEN") if v["checked"] else "not checked"
        extra = f": first counter-example {json.dumps(v['first_counter_example'])}" \
            if v["first_counter_example"] else ""
        echo(f"  {verdict:11s} {name}{extra}")
    t, rl = r["tasks_total"], r["reallocation_latency_s"]
    echo(f"  tasks introduced {t['introduced']}, completed {t['completed']}, failed "
         f"{t['failed']}, unachievable {t['unachievable']}; per hour completed "
         f"{r['tasks_per_hour']['completed']}")
    echo(f"  reallocation after a holder's fault: {rl.get('count', 0)} tasks, median "
         f"{rl.get('median')} s, max {rl.get('max')} s (bound {r['limits']['realloc_bound_s']} s)")
    echo(f"  auction latency drift: {r['auction_latency_drift_s_per_h']} s per hour")
    slopes = {n: m["slope_mib_per_h"] for n, m in r["memory"].items()}
    echo(f"  memory slope (MiB per simulated hour): {slopes}")
    echo(f"  messages per hour {r['messages_per_hour']}")
    echo(f"  faults injected: {r['faults_injected']}")
    if r.get("bus_loss"):
        echo(f"  bus loss (the runner's receiver): {r['bus_loss']}")
    if r.get("wall_time_s") is not None:
        echo(f"  wall time {r['wall_time_s']:.0f} s")
    echo("all invariants held" if r["all_held"] else "error: an invariant broke")


def _plots(out: Path, r: Mapping[str, Any], samples: Sequence[Mapping[str, Any]],
           faults: list[dict[str, Any]], end_t: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    hours = list(range(len(r["messages_per_hour"])))

    def save(fig: Any, name: str) -> None:
        fig.tight_layout()
        fig.savefig(out / name, dpi=90)
        plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4))
    for k in ("introduced", "completed", "failed", "unachievable"):
        ax.plot(hours, r["tasks_per_hour"][k], marker="o", label=k)
    ax.set(xlabel="simulated hour", ylabel="tasks", title="Tasks per hour")
    ax.legend()
    save(fig, "soak-tasks.png")

    fig, ax = plt.subplots(figsize=(8, 4))
    lat = [s["latency_s"] for s in r["reallocation_latency_s"]["samples"]
           if s["latency_s"] is not None]
    ax.hist(lat or [0.0], bins=20, color="#f08c00")
    ax.axvline(r["limits"]["realloc_bound_s"], color="red", linestyle="--", label="bound")
    ax.set(xlabel="fault to back at auction (simulated s)", ylabel="tasks",
           title="Reallocation latency after a holder's fault")
    ax.legend()
    save(fig, "soak-reallocation.png")

    fig, ax = plt.subplots(figsize=(8, 4))
    a = [x for x in r["auction_latency_per_hour"] if x["count"]]
    ax.plot([x["hour"] for x in a], [x["median"] for x in a], marker="o", label="median")
    ax.plot([x["hour"] for x in a], [x["p95"] for x in a], marker="x", label="p95")
    ax.set(xlabel="simulated hour", ylabel="announce to award (simulated s)",
           title="Auction latency per hour")
    ax.legend()
    save(fig, "soak-auction-latency.png")

    fig, ax = plt.subplots(figsize=(8, 5))
    series: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for s in samples:
        if s.get("kind") == "process":
            series[str(s["name"])].append((float(s["t"]) / 3600.0,
                                           float(s["rss_bytes"]) / (1 << 20)))
    for name, pts in sorted(series.items()):
        ax.plot([p[0] for p in pts], [p[1] for p in pts], label=name, linewidth=1)
    ax.axvline(end_t / 7200.0, color="grey", linestyle=":", label="second half from")
    ax.set(xlabel="simulated hours", ylabel="RSS (MiB)", title="Memory per process")
    ax.legend(fontsize=7, ncol=2)
    save(fig, "soak-memory.png")

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(hours, r["messages_per_hour"], color="#3b7dd8")
    ax2 = ax.twinx()
    ax2.plot(hours, [b / 1024 for b in r["bytes_per_hour"]], color="black", marker=".")
    ax.set(xlabel="simulated hour", ylabel="messages", title="MURDOCH messages per hour")
    ax2.set_ylabel("KiB")
    save(fig, "soak-messages.png")

    fig, ax = plt.subplots(figsize=(9, 4))
    kinds = sorted({f["kind"] for f in faults})
    for i, k in enumerate(kinds):
        ts = [float(f["t"]) / 3600.0 for f in faults if f["kind"] == k]
        ax.scatter(ts, [i] * len(ts), marker="|", s=200)
    ax.set_yticks(range(len(kinds)), kinds)
    ax.set(xlabel="simulated hours", title="Faults injected", xlim=(0, max(end_t, 1) / 3600))
    save(fig, "soak-faults.png")
