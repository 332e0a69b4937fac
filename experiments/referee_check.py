"""`check_referee`: drive an experiment's referee through a short scripted run, without a
simulator, and name the first rule it breaks (`murdoch.plugin.ContractError`, one line).

`ScriptedRun` is a `RunHandle` in memory. The script moves its clock (the simulated time each
hook is given) and sets its facts (tasks introduced, awarded, ended; robots down and up); it
keeps what the referee did (`actions`) and refuses on the spot a call that breaks a rule.

The script (simulated seconds, one tick a second, in the runner's order at each tick: the
auction's news, the fault schedule, `before_tasks`, due tasks, `after_tasks`): the first
three tasks of the stream are introduced at 2, 6 and 10 s, announced a tick later and the
first two awarded a tick after that (to the first and second mobile robot); the second
robot is killed at 20 s (its task goes back to the team and fails at 25 s) and started again
at 35 s; the third task is given up as unachievable at 30 s; each of the referee's own fault
actions acts on the last mobile robot, one every 10 s from 40 s; the first task completes at
100 s; the run ends at 120 s (or when the referee ends it). Tasks the referee introduces are
announced and awarded the same way; those it withdraws end at the next tick. The samplers
need the simulator and are not run here (`check_experiment(..., run=True)` runs them).
The script runs twice: the referee must do the same both times.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from itertools import zip_longest
from typing import Any

from experiments import events as ev
from experiments.check_setup import (
    checked_options,
    draw,
    is_json,
    mobile_robots,
    resolve,
    rule,
    world_of,
)
from experiments.plugin import Experiment, PlannedTask, Referee
from murdoch.plugin import ContractError

RUNNER_ACTIONS = frozenset({"kill", "restart", "freeze", "thaw", "retire", "charger-off",
                            "charger-on", "burst"})
"""Fault actions the runner carries out itself; others belong to the experiment's referee."""
RUNNER_KINDS = frozenset({ev.RUN_START, ev.RUN_END, ev.TASK_INTRODUCED, ev.AWARD,
                          ev.REALLOCATION, ev.TASK_OUTCOME, ev.MESSAGE})
"""Event kinds the runner writes for the run's tasks and messages (a referee records others)."""
TICK_S = 1.0
END_S = 120.0


class BrokenRule(Exception):
    """A call of the referee through its `RunHandle` that breaks a rule."""


def _text(value: object) -> bool:
    return isinstance(value, str) and bool(value.strip())


class ScriptedRun:
    """A `RunHandle` in memory: the script's clock and facts, and what the referee did."""

    def __init__(self, robots: Iterable[str], task_kinds: Iterable[str]) -> None:
        self.now = 0.0
        self.kinds = tuple(task_kinds)
        self.actions: list[tuple[Any, ...]] = []
        """What the referee did, in order: (what, now, arguments...)."""
        self.broken: str | None = None
        self.end_reason: str | None = None
        self.closing_reason = "run ended"
        self.announced: list[str] = []
        """Tasks the referee introduced (the script announces and awards them)."""
        self.withdrawn: list[str] = []
        """Tasks the referee withdrew (the script ends them at the next tick)."""
        self._robots = tuple(sorted(robots))
        self._kind_of: dict[str, str] = {}
        self._ended: set[str] = set()
        self._given_up: dict[str, str] = {}
        self._down: set[str] = set()
        self._first: tuple[str, PlannedTask] | None = None

    # -- the script's side
    def at(self, now: float) -> None:
        """The clock at `now` (it never goes back)."""
        assert now >= self.now, (now, self.now)
        self.now = now

    def introduce(self, task_id: str, planned: PlannedTask) -> None:
        """The task source's task introduced now (the first one is `first_task`)."""
        self._kind_of[task_id] = planned.kind
        if self._first is None:
            self._first = (task_id, planned)

    def kind_of(self, task_id: str) -> str:
        return self._kind_of[task_id]

    def task_over(self, task_id: str, unachievable: str | None = None) -> None:
        self._ended.add(task_id)
        if unachievable is not None:
            self._given_up[task_id] = unachievable

    def robot_down(self, name: str, down: bool = True) -> None:
        (self._down.add if down else self._down.discard)(name)

    # -- RunHandle
    def _refuse(self, broken: str) -> None:
        if self.broken is None:
            self.broken = broken
        raise BrokenRule(broken)

    def _at_now(self, call: str, now: float) -> None:
        if not (isinstance(now, (int, float)) and math.isclose(now, self.now, abs_tol=1e-9)):
            self._refuse(f"{call}: now={now!r}, but the hook was called at {self.now:g} s")

    def _robot(self, call: str, name: str) -> None:
        if name not in self._robots:
            self._refuse(f"{call}: no robot {name!r} (robots: {', '.join(self._robots)})")

    def announce(self, planned: PlannedTask, now: float) -> str:
        if not isinstance(planned, PlannedTask):
            self._refuse(f"announce() needs a PlannedTask, found {type(planned).__name__}")
        self._at_now("announce()", now)
        if planned.kind not in self.kinds:
            self._refuse(f"announce(): task kind {planned.kind!r} is not one of its "
                         f"task_kinds ({', '.join(self.kinds) or 'none'})")
        if not (isinstance(planned.params, Mapping) and is_json(dict(planned.params))):
            self._refuse(f"announce(): the params of a {planned.kind!r} task must be JSON "
                         "values")
        task_id = f"r{len(self.announced)}"
        self._kind_of[task_id] = planned.kind
        self.announced.append(task_id)
        self.actions.append(("announce", self.now, task_id, planned.kind,
                             sorted(dict(planned.params).items())))
        return task_id

    def withdraw(self, task_id: str, reason: str) -> None:
        if task_id not in self._kind_of:
            self._refuse(f"withdraw(): no task {task_id!r} was introduced")
        if not _text(reason):
            self._refuse(f"withdraw({task_id!r}): the reason must be a non-empty str")
        if task_id not in self._ended and task_id not in self.withdrawn:
            self.withdrawn.append(task_id)
        self.actions.append(("withdraw", self.now, task_id, reason))

    def first_task(self) -> tuple[str, PlannedTask] | None:
        return self._first

    def task_ended(self, task_id: str) -> bool:
        return task_id in self._ended

    def unachievable(self, task_id: str) -> str | None:
        return self._given_up.get(task_id)

    def robots(self) -> tuple[str, ...]:
        return self._robots

    def down(self) -> frozenset[str]:
        return frozenset(self._down)

    def stop_robot(self, name: str, now: float) -> None:
        self._robot("stop_robot()", name)
        self._at_now("stop_robot()", now)
        self._down.add(name)
        self.actions.append(("stop", self.now, name))

    def start_robot(self, name: str, now: float) -> None:
        self._robot("start_robot()", name)
        self._at_now("start_robot()", now)
        self._down.discard(name)
        self.actions.append(("start", self.now, name))

    def record(self, t_s: float, kind: str, **fields: Any) -> None:
        if not _text(kind):
            self._refuse(f"record(): the event kind must be a non-empty str, found {kind!r}")
        call = f"record({kind!r})"
        if kind in RUNNER_KINDS:
            self._refuse(f"{call}: the runner writes the {kind} events")
        if not (isinstance(t_s, (int, float)) and math.isfinite(t_s)
                and 0.0 <= t_s <= self.now + 1e-9):
            self._refuse(f"{call}: t_s={t_s!r}, expected a time from 0 to now "
                         f"({self.now:g} s)")
        for key, value in fields.items():
            if key == "t":
                self._refuse(f"{call}: field 't' is the event's time (give it as t_s)")
            if not is_json(value):
                self._refuse(f"{call}: field {key!r} is not a JSON value "
                             f"({type(value).__name__})")
        self.actions.append(("record", self.now, kind, t_s, sorted(fields.items())))

    def end(self, reason: str) -> None:
        if not _text(reason):
            self._refuse(f"end(): the reason must be a non-empty str, found {reason!r}")
        if self.end_reason is None:
            self.end_reason = reason
        self.actions.append(("end", self.now, reason))

    def set_closing_reason(self, reason: str) -> None:
        if not _text(reason):
            self._refuse(f"set_closing_reason(): the reason must be a non-empty str, found "
                         f"{reason!r}")
        self.closing_reason = reason
        self.actions.append(("closing", self.now, reason))


# ------------------------------------------------------------------------------ the script
TASK_TIMES = (2.0, 6.0, 10.0)
KILL_S, FAIL_S, UNACHIEVABLE_S, RESTART_S = 20.0, 25.0, 30.0, 35.0
OWN_FAULTS_S, OWN_FAULTS_EVERY_S = 40.0, 10.0
COMPLETE_S = 100.0


@dataclass
class _Script:
    """One pass of the script over a fresh referee."""

    name: str
    referee: Referee
    run: ScriptedRun
    planned: list[PlannedTask]
    workers: tuple[str, ...]
    news: dict[float, list[tuple[str, str, str]]] = field(default_factory=dict)
    followed: int = 0

    def hook(self, what: str, fn: Callable[..., Any], *args: Any) -> None:
        """Call one of the referee's hooks; a rule broken there (or an exception) ends the
        check with one line."""
        try:
            fn(*args)
        except BrokenRule:
            pass
        except Exception as exc:  # the referee's own failure, named
            if self.run.broken is None:
                first = (str(exc).strip().splitlines() or [""])[0]
                raise ContractError(f"experiment {self.name!r}: referee: {what} raised "
                                    f"{type(exc).__name__}: {first}") from None
        if self.run.broken is not None:
            raise ContractError(f"experiment {self.name!r}: referee: {self.run.broken}")

    def later(self, t_s: float, news: str, task_id: str, arg: str = "") -> None:
        self.news.setdefault(round(t_s, 6), []).append((news, task_id, arg))

    def deliver(self, now: float) -> None:
        """The auction's news the runner reads at this tick, in the order it happened."""
        for news, task_id, arg in self.news.pop(round(now, 6), []):
            if news == "announce":
                self.hook(f"on_announce at {now:g} s", self.referee.on_announce, task_id,
                          self.run.kind_of(task_id))
            elif news == "award":
                self.hook(f"on_award at {now:g} s", self.referee.on_award, task_id, arg)
            elif news == "back" or not self.run.task_ended(task_id):
                # back to the team, or over (once): ended (arg: why it is unachievable)
                self.hook(f"on_task_over at {now:g} s", self.referee.on_task_over, task_id)
                if news == "over":
                    self.run.task_over(task_id, arg or None)

    def introduced(self, task_id: str, now: float, robot: str | None) -> None:
        self.later(now + TICK_S, "announce", task_id)
        if robot is not None:
            self.later(now + 2 * TICK_S, "award", task_id, robot)

    def play(self, own: Mapping[str, Callable[[str, float], None]]) -> None:
        run, referee, w = self.run, self.referee, self.workers
        holder, killed, target = w[0], w[min(1, len(w) - 1)], w[-1]
        if len(self.planned) > 1:
            self.later(KILL_S + TICK_S, "back", "t1")
            self.later(FAIL_S, "over", "t1")
        if len(self.planned) > 2:
            self.later(UNACHIEVABLE_S, "over", "t2", "unachievable: no robot bid")
        self.later(COMPLETE_S, "over", "t0")
        faults = {OWN_FAULTS_S + i * OWN_FAULTS_EVERY_S: action
                  for i, action in enumerate(sorted(own))}
        for tick in range(int(END_S / TICK_S) + 1):
            now = tick * TICK_S
            run.at(now)
            self.deliver(now)
            if now in (KILL_S, RESTART_S):
                run.robot_down(killed, now == KILL_S)
            if now in faults:
                self.hook(f"fault action {faults[now]!r} at {now:g} s", own[faults[now]],
                          target, now)
            self.hook(f"before_tasks at {now:g} s", referee.before_tasks, now)
            for i, t_s in enumerate(TASK_TIMES[:len(self.planned)]):
                if t_s == now:
                    run.introduce(f"t{i}", self.planned[i])
                    self.introduced(f"t{i}", now, (holder, killed)[i] if i < 2 else None)
            self.hook(f"after_tasks at {now:g} s", referee.after_tasks, now)
            self._follow_up(now, holder)
            if run.end_reason is not None:
                break

    def _follow_up(self, now: float, holder: str) -> None:
        """What the referee introduced and withdrew at this tick, as the auction goes on."""
        run = self.run
        for task_id in run.announced[self.followed:]:
            self.introduced(task_id, now, holder)
        self.followed = len(run.announced)
        while run.withdrawn:
            self.later(now + TICK_S, "over", run.withdrawn.pop(0))


def _own_actions(name: str, referee: Referee) -> Mapping[str, Callable[[str, float], None]]:
    try:
        own = referee.fault_actions()
    except Exception as exc:  # the referee's own failure, named
        raise ContractError(f"experiment {name!r}: referee: fault_actions() raised "
                            f"{type(exc).__name__}: {exc}") from None
    rule(isinstance(own, Mapping), name, "referee: fault_actions() must give a mapping")
    for action, fn in own.items():
        rule(_text(action) and callable(fn), name,
             f"referee: fault action {action!r} must be a name and a function (robot, now)")
        rule(action not in RUNNER_ACTIONS, name,
             f"referee: fault action {action!r} is the runner's own")
    return own


def _samplers(name: str, referee: Referee) -> None:
    samplers = getattr(referee, "samplers", None)
    ok = isinstance(samplers, tuple) and all(
        isinstance(s, tuple) and len(s) == 2 and isinstance(s[0], (int, float))
        and math.isfinite(s[0]) and s[0] >= 0 and callable(s[1]) for s in samplers)
    rule(ok, name, "referee: samplers must be a tuple of (period_s >= 0, function of "
                   "(sim, t))")


def _pass(name: str, referee: Referee, planned: list[PlannedTask], robots: tuple[str, ...],
          workers: tuple[str, ...], kinds: tuple[str, ...]) -> ScriptedRun:
    run = ScriptedRun(robots, kinds)
    _samplers(name, referee)
    own = _own_actions(name, referee)
    script = _Script(name, referee, run, planned, workers)
    script.hook("bind", referee.bind, run)
    script.play(own)
    return run


def _said(action: tuple[Any, ...] | None) -> str:
    if action is None:
        return "nothing"
    text = " ".join(str(v) for v in (action[0], *action[2:]))
    return text if len(text) <= 60 else text[:57] + "..."


def check_referee(experiment: Experiment | str, *, duration_s: float = 3600.0,
                  seed: int = 1) -> ScriptedRun:
    """Drive the experiment's referee (or that of the registered experiment of that name)
    through the script twice; `ContractError` names the first rule it breaks. The first
    pass's `ScriptedRun` (what the referee did) is returned."""
    plugin = resolve(experiment)
    name = plugin.name
    spec = world_of(plugin)
    options = checked_options(plugin, spec, duration_s, seed)
    planned = draw(plugin, spec, options)[:len(TASK_TIMES)]
    robots = tuple(r.name for r in spec.robots)
    workers, kinds = mobile_robots(spec), tuple(plugin.task_kinds)
    first, second = (_pass(name, plugin.referee(spec, options), planned, robots, workers,
                           kinds) for _ in range(2))
    if first.actions != second.actions:
        a, b = next((a, b) for a, b in zip_longest(first.actions, second.actions) if a != b)
        t_s = (a or b)[1]
        rule(False, name, f"referee: it must do the same in the same scripted run (no clocks, "
                          f"no global random numbers); at {t_s:g} s it did {_said(a)}, then "
                          f"{_said(b)}")
    return first
