"""A soak run's fault schedule: drawn from the seed at start, or read from a file (pure).

Robot faults come as episodes that never overlap one another, so each one's effect can be
told apart: a process killed and restarted, or a process frozen (stopped) and continued.
A kill or freeze aims at `busy` (the first mobile robot holding a task at that tick, resolved
by the runner; a fault that finds nobody busy is recorded as `fault_skipped`), and its restart
or thaw at `same` (the robot that kill or freeze picked; skipped too when it found nobody).
One named robot is switched off for good part-way through, outside every episode. Charger
outages (one charger at a time) and task bursts are drawn independently. Times are simulated
seconds.
"""

from __future__ import annotations

import json
import random
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from experiments.run_loop import Fault

ROBOT_ACTIONS = ("kill", "restart", "freeze", "thaw", "retire")
CHARGER_ACTIONS = ("charger-off", "charger-on")
ACTIONS = (*ROBOT_ACTIONS, *CHARGER_ACTIONS, "burst")


class FaultFileError(ValueError):
    """A fault file that cannot be used; the message names the file and the entry."""


@dataclass(frozen=True)
class FaultMix:
    """Rates and sizes of the random faults (per simulated hour where a rate)."""

    kills_per_h: float = 1.0
    kill_down_s: tuple[float, float] = (30.0, 300.0)
    freezes_per_h: float = 1.0
    freeze_s: tuple[float, float] = (5.0, 60.0)
    switch_offs: int = 1
    charger_outages_per_h: float = 0.5
    charger_outage_s: tuple[float, float] = (300.0, 1200.0)
    bursts: int = 1
    burst_size: int = 20
    quiet_start_s: float = 120.0
    """No fault before this (the team settles in)."""
    quiet_end_s: float = 300.0
    """No fault starts this close to the end (its effect must be observable)."""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def draw_schedule(rng: random.Random, span_s: float, mobile: list[str], chargers: list[str],
                  mix: FaultMix) -> list[Fault]:
    """The random schedule for a run of `span_s` simulated seconds."""
    lo, hi = mix.quiet_start_s, span_s - mix.quiet_end_s
    out: list[Fault] = []
    if hi <= lo:
        return out
    # robot episodes: a sequence of kills and freezes with exponential gaps
    rate = mix.kills_per_h + mix.freezes_per_h
    episodes: list[tuple[float, float, str]] = []  # start, end, kind
    t = lo
    while rate > 0:
        t += rng.expovariate(rate / 3600.0)
        kind = "kill" if rng.random() < mix.kills_per_h / rate else "freeze"
        bounds = mix.kill_down_s if kind == "kill" else mix.freeze_s
        end = t + rng.uniform(*bounds)
        if end >= hi:
            break
        episodes.append((t, end, kind))
        t = end
    # switched off for good: named robots (never all of them), outside every episode
    candidates = sorted(mobile)
    rng.shuffle(candidates)
    retired = candidates[:max(0, min(mix.switch_offs, len(candidates) - 1))]
    for name in retired:
        at = rng.uniform(lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo))
        episodes = [e for e in episodes if not e[0] - 1.0 <= at <= e[1] + 1.0]
        out.append(Fault(round(at, 1), "retire", name))
    for start, end, kind in episodes:
        back = "restart" if kind == "kill" else "thaw"
        out.append(Fault(round(start, 1), kind, "busy"))
        out.append(Fault(round(end, 1), back, "same"))
    # charger outages, one charger at a time
    t = lo
    while chargers and mix.charger_outages_per_h > 0:
        t += rng.expovariate(mix.charger_outages_per_h / 3600.0)
        end = t + rng.uniform(*mix.charger_outage_s)
        if end >= hi:
            break
        name = rng.choice(sorted(chargers))
        out.append(Fault(round(t, 1), "charger-off", name))
        out.append(Fault(round(end, 1), "charger-on", name))
        t = end
    for _ in range(mix.bursts):
        out.append(Fault(round(rng.uniform(lo, hi), 1), "burst", "", mix.burst_size))
    return sorted(out, key=lambda f: (f.t_s, f.action, f.robot))


def fault_to_dict(f: Fault) -> dict[str, Any]:
    d: dict[str, Any] = {"t_s": f.t_s, "action": f.action, "robot": f.robot}
    if f.action == "burst":
        d["count"] = f.count
    return d


def load_schedule(path: Path, robots: list[str], chargers: list[str]) -> list[Fault]:
    """A schedule from a JSON file: a list of {"t_s", "action", "robot"[, "count"]} (the
    `faults` entry of a soak run's config.json is one). Errors name the file and entry."""
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise FaultFileError(f"{path}: cannot read it: {exc.strerror}") from exc
    except json.JSONDecodeError as exc:
        raise FaultFileError(f"{path}: not JSON ({exc.msg}, line {exc.lineno})") from exc
    if isinstance(data, dict) and "faults" in data:
        data = data["faults"]
    if not isinstance(data, list):
        raise FaultFileError(f"{path}: expected a list of faults, found {type(data).__name__}")
    out = []
    for i, d in enumerate(data):
        where = f"{path}: fault {i}"
        if not isinstance(d, dict):
            raise FaultFileError(f"{where}: expected an object, found {d!r}")
        action = d.get("action")
        if action not in ACTIONS:
            raise FaultFileError(f"{where}: action must be one of {', '.join(ACTIONS)}, "
                                 f"found {action!r}")
        t = d.get("t_s")
        if not isinstance(t, int | float) or isinstance(t, bool) or not 0 <= t < 1e9:
            raise FaultFileError(f"{where}: t_s must be simulated seconds >= 0, found {t!r}")
        target = d.get("robot", "")
        if action in ROBOT_ACTIONS:
            allowed = ([*robots, "busy"] if action in ("kill", "freeze")
                       else [*robots, "same"] if action in ("restart", "thaw") else robots)
            if target not in allowed:
                raise FaultFileError(f"{where}: robot must be one of {', '.join(allowed)}, "
                                     f"found {target!r}")
        elif action in CHARGER_ACTIONS and target not in chargers:
            raise FaultFileError(f"{where}: robot must name a charger "
                                 f"({', '.join(chargers)}), found {target!r}")
        count = d.get("count", 0)
        if action == "burst" and (not isinstance(count, int) or not 0 < count <= 1000):
            raise FaultFileError(f"{where}: count must be 1..1000 tasks, found {count!r}")
        out.append(Fault(float(t), action, str(target), int(count) if action == "burst" else 0))
    return sorted(out, key=lambda f: (f.t_s, f.action, f.robot))
