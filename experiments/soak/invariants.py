"""The invariants of a soak run, checked on simulation-time facts (pure).

`EventInvariants` takes a run's events one at a time (so it can run while the run goes, fed
from events.jsonl) and keeps, for each invariant, whether it still holds and its first
counter-example:

- `terminal_states`: every task introduced ends in exactly one terminal state (no second
  outcome, no outcome of a task never introduced, none left open at the end);
- `exclusive_execution`: no task is executed by two robots at once for longer than
  `OVERLAP_GRACE_S` of simulated time, and a group task taken whole (introduced with
  `required` robots in its params) by no more than its group (a robot executes from its
  `robot_task` start until
  its own end of that task, its death, or its switch-off; a frozen robot's execution is
  suspended and resumes at its thaw);
- `reallocation_bound`: every task held by a robot when it was killed, frozen, switched off or
  died is back at auction (`reallocation`) or ended within `realloc_bound_s` (a frozen holder
  that is continued within the bound and keeps its task also satisfies it);
- `charging`: every robot whose battery is below the low mark while its controller runs
  reaches a charger (`charge_start`) within `charge_bound_s`, the bound stretched by any
  charger outage in between.

Two more are checked at the end from other files: `dead_controller_still` (no robot drives while
its controller is dead: the drive command recorded with each odometry sample must be zero once
the watchdog had time to act, `check_dead_controllers`; a parked robot that others bump moves
without driving) and
`memory_flat` (least-squares slope of each process's resident memory over the second half of
the run, `memory_slopes`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from murdoch.auction.timing import USER_TASK

WATCHDOG_S = 2.0
"""The Player server's communication watchdog (simulated seconds)."""
DEAD_GRACE_S = WATCHDOG_S + 1.0
"""A dead controller's robot must stand still from this long after its death."""
OVERLAP_GRACE_S = 0.5
"""A robot continued after a freeze first reads the round it stopped at, then the current one:
it needs a tick or two to hear that its task went to another robot meanwhile. Two robots
executing one task for longer than this is a breach."""
MOVING_MPS = 0.02
MOVING_RADPS = 0.05
BATTERY_LOW_PERCENT = 25.0
"""The robots' default `--battery-low`."""


@dataclass(frozen=True)
class Limits:
    realloc_bound_s: float
    charge_bound_s: float = 900.0
    memory_slope_mib_per_h: float = 2.0
    battery_low_percent: float = BATTERY_LOW_PERCENT

    @staticmethod
    def defaults(realloc_bound_s: float | None = None,
                 memory_slope_mib_per_h: float = 2.0) -> Limits:
        """The reallocation bound defaults to what the auction's timing allows: a silent
        winner is dropped `contract_timeout_s` after its last progress, which came at most a
        `renew_period_s` before it fell silent, plus a bid window of slack (13 s)."""
        if realloc_bound_s is None:
            realloc_bound_s = (USER_TASK.contract_timeout_s + USER_TASK.renew_period_s
                               + USER_TASK.bid_window_s)
        return Limits(realloc_bound_s=realloc_bound_s,
                      memory_slope_mib_per_h=memory_slope_mib_per_h)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


@dataclass
class Verdict:
    name: str
    description: str
    held: bool = True
    checked: bool = True
    first_counter_example: dict[str, Any] | None = None
    breaches: int = 0
    note: str = ""

    def breach(self, example: dict[str, Any]) -> bool:
        """Record a counter-example; True if it is the first."""
        self.breaches += 1
        if self.held:
            self.held = False
            self.first_counter_example = example
            return True
        return False

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


DESCRIPTIONS = {
    "terminal_states": "every task introduced ends in exactly one terminal state",
    "exclusive_execution": "no task executed by two robots at once",
    "reallocation_bound": "every killed, frozen or switched-off holder's task back at auction "
                          "or ended within the bound",
    "charging": "every robot that should charge reaches a charger",
    "dead_controller_still": "no robot drives with a dead controller",
    "memory_flat": "no process's memory grows",
}


@dataclass
class _Pending:
    t: float
    robot: str
    cause: str


@dataclass
class EventInvariants:
    limits: Limits
    verdicts: dict[str, Verdict] = field(default_factory=dict)
    introduced: set[str] = field(default_factory=set)
    ended: dict[str, float] = field(default_factory=dict)
    executing: dict[str, set[str]] = field(default_factory=dict)  # task -> robots
    suspended: dict[str, set[str]] = field(default_factory=dict)  # robot -> tasks (frozen)
    conflicts: dict[str, tuple[float, tuple[str, ...]]] = field(default_factory=dict)
    holder: dict[str, set[str]] = field(default_factory=dict)  # task -> robots (awards)
    allowed: dict[str, int] = field(default_factory=dict)  # task -> robots at once (> 1)
    pending: dict[str, _Pending] = field(default_factory=dict)  # task -> fault awaiting
    realloc_latencies: list[dict[str, Any]] = field(default_factory=list)
    down: set[str] = field(default_factory=set)  # controller dead or stopped
    need_charge: dict[str, float] = field(default_factory=dict)  # robot -> since
    charging: set[str] = field(default_factory=set)
    outages: dict[str, float] = field(default_factory=dict)  # charger -> off since
    outage_spans: list[tuple[float, float]] = field(default_factory=list)
    last_t: float = 0.0
    first_breaches: list[tuple[str, dict[str, Any]]] = field(default_factory=list)

    def __post_init__(self) -> None:
        for name in ("terminal_states", "exclusive_execution", "reallocation_bound",
                     "charging"):
            self.verdicts[name] = Verdict(name, DESCRIPTIONS[name])

    # -- feeding ---------------------------------------------------------------------------
    def _breach(self, name: str, example: dict[str, Any]) -> None:
        if self.verdicts[name].breach(example):
            self.first_breaches.append((name, example))

    def apply(self, e: Mapping[str, Any]) -> None:
        t = float(e.get("t", self.last_t))
        if t > self.last_t:
            self._advance(t)
            self.last_t = t
        kind = e.get("kind")
        handler = getattr(self, "_on_" + str(kind), None)
        if handler is not None:
            handler(t, e)

    def _advance(self, t: float) -> None:
        """Time moves on to t: conflicts that lasted are breaches; deadlines that passed."""
        for task, (since, robots) in list(self.conflicts.items()):
            if t <= since + OVERLAP_GRACE_S:
                continue
            if len(self.executing.get(task, ())) > self.allowed.get(task, 1):
                self._breach("exclusive_execution", {"t": since, "task": task,
                                                     "robots": list(robots)})
            del self.conflicts[task]
        bound = self.limits.realloc_bound_s
        for task, p in list(self.pending.items()):
            if t > p.t + bound + 1e-9:
                self._breach("reallocation_bound", {
                    "t": p.t, "task": task, "robot": p.robot, "cause": p.cause,
                    "bound_s": bound, "still_unresolved_at": t})
                self.realloc_latencies.append({"task": task, "robot": p.robot,
                                               "cause": p.cause, "fault_t": p.t,
                                               "latency_s": None, "how": "too late"})
                del self.pending[task]
        for robot, since in list(self.need_charge.items()):
            if t > self._charge_deadline(since, t):
                self._breach("charging", {"t": since, "robot": robot,
                                          "bound_s": self.limits.charge_bound_s,
                                          "no_charge_start_by": t})
                del self.need_charge[robot]

    def _charge_deadline(self, since: float, now: float) -> float:
        deadline = since + self.limits.charge_bound_s
        spans = [*self.outage_spans, *((s, now) for s in self.outages.values())]
        for a, b in spans:
            overlap = min(b, deadline) - max(a, since)
            if overlap > 0:
                deadline += overlap
        return deadline

    # -- tasks -----------------------------------------------------------------------------
    def _on_task_introduced(self, t: float, e: Mapping[str, Any]) -> None:
        self.introduced.add(str(e["task"]))
        params = e.get("params")
        if e.get("source") == "group" and isinstance(params, Mapping) and "members" in params:
            self.allowed[str(e["task"])] = len(params["members"])

    def _on_task_outcome(self, t: float, e: Mapping[str, Any]) -> None:
        task = str(e["task"])
        if task in self.ended:
            self._breach("terminal_states", {"t": t, "task": task,
                                             "problem": "a second terminal state",
                                             "outcome": e.get("outcome")})
        elif task not in self.introduced:
            self._breach("terminal_states", {"t": t, "task": task,
                                             "problem": "an outcome of a task never "
                                                        "introduced"})
        self.ended[task] = t
        self.holder.pop(task, None)
        self._resolve(task, t, "ended")

    def _on_award(self, t: float, e: Mapping[str, Any]) -> None:
        task = str(e["task"])
        if "seat" not in e:
            self.holder[task] = set()
        self.holder.setdefault(task, set()).add(str(e["robot"]))

    def _on_reallocation(self, t: float, e: Mapping[str, Any]) -> None:
        task = str(e["task"])
        if str(e["from_robot"]) in self.holder.get(task, ()):
            del self.holder[task]  # (a group goes back whole)
        self._resolve(task, t, "reallocated")

    def _on_bid_declined(self, t: float, e: Mapping[str, Any]) -> None:
        self.holder.get(str(e["task"]), set()).discard(str(e["robot"]))

    def _resolve(self, task: str, t: float, how: str) -> None:
        p = self.pending.pop(task, None)
        if p is not None:
            self.realloc_latencies.append({"task": task, "robot": p.robot, "cause": p.cause,
                                           "fault_t": p.t, "latency_s": round(t - p.t, 3),
                                           "how": how})

    def _on_robot_task(self, t: float, e: Mapping[str, Any]) -> None:
        task, robot, phase = str(e.get("task", "")), str(e["robot"]), e.get("phase")
        if not task:
            return
        running = self.executing.setdefault(task, set())
        if phase == "start":
            running.add(robot)
            self._check_overlap(task, t)
        else:
            running.discard(robot)

    def _check_overlap(self, task: str, t: float) -> None:
        running = self.executing.get(task, set())
        if len(running) > self.allowed.get(task, 1) and task not in self.conflicts:
            self.conflicts[task] = (t, tuple(sorted(running)))

    # -- robots ----------------------------------------------------------------------------
    def _controller_lost(self, t: float, robot: str, cause: str, *, suspend: bool) -> None:
        self.down.add(robot)
        self.need_charge.pop(robot, None)
        tasks = sorted(task for task, rs in self.executing.items() if robot in rs)
        for task in tasks:
            self.executing[task].discard(robot)
        if suspend:
            self.suspended[robot] = set(tasks)
        else:
            self.suspended.pop(robot, None)  # killed while frozen: it never resumes those
        for task, holders in sorted(self.holder.items()):
            if robot in holders and task not in self.ended and task not in self.pending:
                self.pending[task] = _Pending(t, robot, cause)

    def _on_robot_failure(self, t: float, e: Mapping[str, Any]) -> None:
        self._controller_lost(t, str(e["robot"]), str(e.get("reason", "failed")),
                              suspend=False)

    def _on_robot_switch_off(self, t: float, e: Mapping[str, Any]) -> None:
        self._controller_lost(t, str(e["robot"]), "switched-off", suspend=False)

    def _on_robot_freeze(self, t: float, e: Mapping[str, Any]) -> None:
        self._controller_lost(t, str(e["robot"]), "frozen", suspend=True)

    def _on_robot_thaw(self, t: float, e: Mapping[str, Any]) -> None:
        robot = str(e["robot"])
        self.down.discard(robot)
        for task in sorted(self.suspended.pop(robot, set())):
            if task not in self.ended:
                self.executing.setdefault(task, set()).add(robot)
                self._check_overlap(task, t)
        for task, p in list(self.pending.items()):
            if p.robot == robot and robot in self.holder.get(task, ()):
                # back before the auctioneer gave up on it, still the holder
                self._resolve(task, t, "holder continued")

    def _on_robot_restart(self, t: float, e: Mapping[str, Any]) -> None:
        self.down.discard(str(e["robot"]))

    def _on_robot_switch_on(self, t: float, e: Mapping[str, Any]) -> None:
        self.down.discard(str(e["robot"]))

    # -- charging --------------------------------------------------------------------------
    def _on_battery(self, t: float, e: Mapping[str, Any]) -> None:
        percent = e.get("percent")
        if not isinstance(percent, Mapping):
            return
        for robot, p in sorted(percent.items()):
            if (robot in self.down or robot in self.charging or robot in self.need_charge
                    or not isinstance(p, int | float)):
                continue
            if p < self.limits.battery_low_percent:
                self.need_charge[robot] = t

    def _on_charge_start(self, t: float, e: Mapping[str, Any]) -> None:
        robot = str(e["robot"])
        self.charging.add(robot)
        self.need_charge.pop(robot, None)

    def _on_charge_end(self, t: float, e: Mapping[str, Any]) -> None:
        self.charging.discard(str(e["robot"]))

    def _on_charger_off(self, t: float, e: Mapping[str, Any]) -> None:
        self.outages.setdefault(str(e["charger"]), t)

    def _on_charger_on(self, t: float, e: Mapping[str, Any]) -> None:
        since = self.outages.pop(str(e["charger"]), None)
        if since is not None:
            self.outage_spans.append((since, t))

    # -- the end ---------------------------------------------------------------------------
    def finish(self, end_t: float) -> dict[str, Verdict]:
        """Close the books at the end of the run (open tasks, deadlines not yet due)."""
        self._advance(end_t + 1e-6)
        for task in sorted(self.introduced - set(self.ended)):
            self._breach("terminal_states", {"t": end_t, "task": task,
                                             "problem": "no terminal state"})
        for task, p in sorted(self.pending.items()):
            self.realloc_latencies.append({"task": task, "robot": p.robot, "cause": p.cause,
                                           "fault_t": p.t, "latency_s": None,
                                           "how": "run ended"})
        return self.verdicts


def check_events(events: Iterable[Mapping[str, Any]], limits: Limits,
                 end_t: float | None = None) -> EventInvariants:
    inv = EventInvariants(limits)
    for e in events:
        inv.apply(e)
    inv.finish(inv.last_t if end_t is None else end_t)
    return inv


# -- dead controllers ---------------------------------------------------------------------
def dead_spans(events: Iterable[Mapping[str, Any]], end_t: float) -> dict[str, list[
        tuple[float, float]]]:
    """Per robot, the spans of simulated time during which its controller was dead or
    stopped (killed, exited, frozen, switched off), each from its start to its restart."""
    since: dict[str, float] = {}
    spans: dict[str, list[tuple[float, float]]] = {}
    for e in events:
        kind, robot = e.get("kind"), e.get("robot")
        if not isinstance(robot, str):
            continue
        t = float(e["t"])
        if kind in ("robot_failure", "robot_freeze", "robot_switch_off"):
            since.setdefault(robot, t)
        elif kind in ("robot_restart", "robot_thaw", "robot_switch_on") and robot in since:
            spans.setdefault(robot, []).append((since.pop(robot), t))
    for robot, t in since.items():
        spans.setdefault(robot, []).append((t, end_t))
    return spans


def check_dead_controllers(spans: Mapping[str, list[tuple[float, float]]],
                           drive: Iterable[tuple[str, float, float, float]],
                           what: str = "drive commands") -> Verdict:
    """`drive`: (robot, t, forward speed, yaw rate) samples in any order, the speeds the drive
    was commanded to (a recording without commands gives the measured ones). A sample inside a
    dead span, more than `DEAD_GRACE_S` after its start, must show a robot not driving."""
    v = Verdict("dead_controller_still", DESCRIPTIONS["dead_controller_still"])
    checked = 0
    first: tuple[float, dict[str, Any]] | None = None
    for robot, t, vx, vyaw in drive:
        for a, b in spans.get(robot, ()):
            if a + DEAD_GRACE_S <= t < b:
                checked += 1
                if abs(vx) > MOVING_MPS or abs(vyaw) > MOVING_RADPS:
                    v.breaches += 1
                    if first is None or t < first[0]:
                        first = (t, {"t": t, "robot": robot, "dead_since": a,
                                     "speed_mps": round(vx, 3), "yaw_rate": round(vyaw, 3)})
                break
    if first is not None:
        v.held = False
        v.first_counter_example = first[1]
    v.note = f"{checked} {what} inside dead spans"
    return v


# -- memory ---------------------------------------------------------------------------------
def slope_per_hour(points: list[tuple[float, float]]) -> float:
    """Least-squares slope of (t seconds, value) in value per hour."""
    n = len(points)
    mt = sum(t for t, _ in points) / n
    mv = sum(v for _, v in points) / n
    var = sum((t - mt) ** 2 for t, _ in points)
    if var <= 0:
        return 0.0
    cov = sum((t - mt) * (v - mv) for t, v in points)
    return cov / var * 3600.0


MIN_MEMORY_SAMPLES = 4
WARMUP_S = 600.0
"""A process's first simulated minutes (imports, first tasks, buffers) are not judged."""


def memory_slopes(samples: Iterable[Mapping[str, Any]], end_t: float,
                  limit_mib_per_h: float) -> tuple[Verdict, dict[str, dict[str, Any]]]:
    """From `process` samples (name, pid, rss_bytes, t): for each process name, the slope of
    its longest-lived pid's RSS over the second half of the run (and after its first
    `WARMUP_S`, counted from its `process_note` "started", or from 0 for a process there
    from the start, such as the runner), in MiB per simulated hour. A host process of
    several robots (its samples' ``robots``) is judged per robot: its slope over its robots
    is held to the limit, as each would be in a process of its own."""
    series: dict[tuple[str, int], list[tuple[float, float]]] = {}
    started: dict[int, float] = {}
    robots: dict[str, int] = {}
    for s in samples:
        if s.get("kind") == "process_note" and s.get("what") == "started":
            started.setdefault(int(s["pid"]), float(s["t"]))  # a host's first robot
        if s.get("kind") != "process":
            continue
        name = str(s["name"])
        robots[name] = max(robots.get(name, 1), int(s.get("robots", 1)))
        series.setdefault((name, int(s["pid"])), []).append(
            (float(s["t"]), float(s["rss_bytes"]) / (1 << 20)))
    by_name: dict[str, list[tuple[float, float]]] = {}
    for (name, pid), pts in sorted(series.items()):
        # a process restarted late in the run is judged after it has warmed up
        since = max(end_t / 2.0, started.get(pid, 0.0) + WARMUP_S)
        pts = [p for p in pts if p[0] >= since]
        if len(pts) > len(by_name.get(name, ())):
            by_name[name] = pts
    v = Verdict("memory_flat", DESCRIPTIONS["memory_flat"])
    out: dict[str, dict[str, Any]] = {}
    worst: tuple[float, str] | None = None
    for name, pts in sorted(by_name.items()):
        if len(pts) < MIN_MEMORY_SAMPLES:
            out[name] = {"samples": len(pts), "slope_mib_per_h": None}
            continue
        slope = slope_per_hour(pts) / robots[name]
        out[name] = {"samples": len(pts), "slope_mib_per_h": round(slope, 3),
                     "first_mib": round(pts[0][1], 1), "last_mib": round(pts[-1][1], 1),
                     "from_t": pts[0][0], "to_t": pts[-1][0]}
        if robots[name] > 1:
            out[name]["robots"] = robots[name]  # the slope is per robot
        if slope > limit_mib_per_h and (worst is None or slope > worst[0]):
            worst = (slope, name)
        if slope > limit_mib_per_h:
            v.breaches += 1
    if worst is not None:
        v.held = False
        v.first_counter_example = {"process": worst[1], **out[worst[1]],
                                   "limit_mib_per_h": limit_mib_per_h}
    if not any(d["slope_mib_per_h"] is not None for d in out.values()):
        v.checked = False
        v.note = (f"fewer than {MIN_MEMORY_SAMPLES} memory samples per process in the second "
                  f"half of the run")
    return v, out
