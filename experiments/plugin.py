"""The public API of experiments and task kinds (re-exported by `murdoch_api`).

An experiment is an object implementing `Experiment` (most start from `ExperimentBase`):
its name, the world it runs in by default, the command-line options it owns (`Option`),
the task kinds it introduces, what it supports (`Supports`: soak, compare, which
allocators), its task source, and optional parts: a referee that watches the run on the
serving thread (`Referee`), faults of its own options, summary sections, plots, end lines
and a verdict. Everything else (the simulator, the Player server, the robot processes, the
team's allocator, the recording) is the same for every experiment.

A task kind is a `TaskKind`: its parameters (defaults, required ones), its duration (the
parameter holding it), where a task takes place (`place`, a function of the parameters and
a `TaskSite`), the resources a robot needs and the behaviour composition that executes it.

Experiments and task kinds of other packages are registered through the entry point groups
``murdoch.experiments`` and ``murdoch.tasks`` (docs/extending.md); `check_experiment` and
`check_task_kind` drive one through the contract and name the rule it breaks.

Stable names (kept compatible across minor versions): `Option`, `Supports`, `RunOptions`,
`Experiment`, `ExperimentBase`, `Referee`, `NoReferee`, `RunHandle`, `Fault`, `Verdict`,
`PlannedTask`, `TaskKind`, `TaskSite`, `Place`, `default_place`, `OptionError`,
`PluginError`, `robot_at_time`, `duration`, `fraction`; and the checkers
`experiments.plugin_check.check_experiment`, `experiments.referee_check.check_referee` (with
its `ScriptedRun`) and `behaviors.task_kinds.check_task_kind` (`murdoch_api` re-exports them
all). Everything else in `experiments` is internal.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import click

from behaviors.library import TaskSpec as TaskKind
from behaviors.task_place import Place, TaskSite, default_place
from experiments.task_source import PlannedTask
from murdoch.plugin_loading import PluginError

if TYPE_CHECKING:
    from worlds import WorldSpec

__all__ = [
    "Experiment", "ExperimentBase", "Fault", "NoReferee", "Option", "OptionError", "Place",
    "PlannedTask", "PluginError", "Referee", "RunHandle", "RunOptions", "Sampler",
    "Supports", "TaskKind", "TaskSite", "Verdict", "default_place", "duration", "fraction",
    "labels", "robot_at_time",
]


class OptionError(click.BadParameter):
    """An option's value that cannot be used: one line naming the option."""

    def __init__(self, flag: str, message: str) -> None:
        super().__init__(message, param_hint=flag)


# ------------------------------------------------------------------------------ options
def duration(text: str) -> float:
    """'90m', '2h', '45s' or plain seconds -> seconds (an `Option` type)."""
    from experiments.durations import parse_duration_s

    return parse_duration_s(text)


def robot_at_time(text: str) -> tuple[str, float]:
    """'p3@30m' -> ('p3', 1800.0) (an `Option` type)."""
    from experiments.durations import parse_at

    return parse_at(text)


def fraction(text: str) -> float:
    """A number from 0 to 1 (an `Option` type)."""
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"expected a fraction from 0 to 1, found {text}")
    return value


@dataclass(frozen=True)
class Option:
    """A command-line option an experiment owns (`murdoch run`, `soak` and `compare` offer
    it; given to another experiment it is refused).

    `type` turns the text into a value: ``str``, ``int``, ``float``, ``bool`` (a flag) or
    any function of the text that raises ``ValueError`` with a message when it cannot.
    With `multiple` the option may be repeated and its value is a tuple."""

    flag: str
    help: str
    type: Callable[[str], Any] = str
    default: Any = None
    multiple: bool = False
    metavar: str | None = None

    @property
    def dest(self) -> str:
        """The key of its value in `RunOptions.own`: '--group-tasks' -> 'group_tasks'."""
        return self.flag.lstrip("-").replace("-", "_")


@dataclass(frozen=True)
class Supports:
    """What an experiment can be used with."""

    soak: bool = False
    """`murdoch soak` may run it for hours under faults."""
    compare: bool = False
    """`murdoch compare` may run it once per allocator and seed."""
    allocators: tuple[str, ...] | None = None
    """The allocators its robots may use (None: every registered one)."""
    sub_tasks: bool = False
    """Its robots auction sub-tasks: only allocators that offer them."""
    soak_options: tuple[tuple[str, Any], ...] = ()
    """(`Option.dest`, value) pairs `murdoch soak` uses for its own options not given on the
    command line (e.g. an experiment that ends by itself asked to start over until the
    soak's span ends)."""


@dataclass(frozen=True)
class RunOptions:
    """The options of one run an experiment reads: those of every run, and `own`, the values
    of its own `Option`s by `Option.dest` (as parsed, or as its `check` made them)."""

    duration_s: float
    seed: int
    task_interval_s: float = 240.0
    allocator: str = "murdoch"
    own: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, experiment: Experiment, duration_s: float, seed: int, *,
           task_interval_s: float = 240.0, allocator: str = "murdoch",
           **own: Any) -> RunOptions:
        """The options of a run of `experiment`: its own options at their declared defaults
        unless given in `own` (by `Option.dest`)."""
        values = {o.dest: (tuple(o.default or ()) if o.multiple else o.default)
                  for o in experiment.options}
        values.update(own)
        return cls(duration_s, seed, task_interval_s, allocator, values)

    def get(self, dest: str, default: Any = None) -> Any:
        """The value of its own option `dest` (`default` if it was not set)."""
        value = self.own.get(dest)
        return default if value is None else value


# --------------------------------------------------------------------------- the run
@dataclass(frozen=True)
class Fault:
    """One entry of the fault schedule: `action` on `robot` at simulation time `t_s`.

    Actions: kill, restart, switch-off, switch-on (boxpush), and for soak runs freeze, thaw
    (a robot's process stopped and continued, `hold_clock`), retire (switched off for good),
    charger-off, charger-on (`robot` names the charger) and burst (`count` tasks at once from
    the burst source); an experiment's referee may add actions of its own."""

    t_s: float
    action: str
    robot: str
    count: int = 0

    def label(self) -> str:
        return f"{self.robot}@{self.t_s:g}s"


Sampler = tuple[float, Callable[[Any, float], None]]
"""(period in simulated seconds, 0 = every step; a function of (sim, t)) run between steps."""


class RunHandle(Protocol):
    """What a referee may ask of and do to the run it watches (the runner's loop).

    Called from the referee's hooks, on the serving thread: a question is answered as of the
    tick boundary the hook runs at; an action takes effect at that tick. Times are simulated
    seconds; `now` is the time the hook was given. `experiments.referee_check.ScriptedRun`
    is an in-memory one for checks."""

    # -- tasks
    def announce(self, planned: PlannedTask, now: float) -> str:
        """Introduce a task now, as the user (its `task_introduced` event at `now`; it is
        auctioned from this tick on and reintroduced with backoff while unachievable); its
        id. Its kind is one of the experiment's `task_kinds`."""
        ...

    def withdraw(self, task_id: str, reason: str) -> None:
        """The user withdraws a task it introduced, at this tick: its auction ends, its
        holder is told to stop, and it ends as failed with `reason` (`on_task_over` follows
        as for any end). A task that has ended already is left as it is."""
        ...

    def first_task(self) -> tuple[str, PlannedTask] | None:
        """The first task the experiment's task source introduced: its id and the task as
        planned (None until it is introduced, at or after its planned time)."""
        ...

    def task_ended(self, task_id: str) -> bool:
        """Whether the task has its outcome (completed, failed or unachievable) by now."""
        ...

    def unachievable(self, task_id: str) -> str | None:
        """Why the team gave the task up as unachievable, if it has by now (else None)."""
        ...

    # -- robots
    def robots(self) -> tuple[str, ...]:
        """The names of the run's robots (each a process of its own), sorted."""
        ...

    def down(self) -> frozenset[str]:
        """The robots down now: killed, switched off or exited by themselves, and not
        started again since."""
        ...

    def stop_robot(self, name: str, now: float) -> None:
        """Switch the robot off now: its process ends at once, it is down (the lockstep
        clock no longer waits for it) until `start_robot`, and the tasks it held go back to
        the team as after any failure. The referee records why (`record`)."""
        ...

    def start_robot(self, name: str, now: float) -> None:
        """Start the robot's process now (replacing one still running); it is no longer
        down, and the lockstep clock waits for it from the next tick."""
        ...

    # -- the record and the end
    def record(self, t_s: float, kind: str, **fields: Any) -> None:
        """Add an event of `kind` at `t_s` (no later than now) to events.jsonl; its fields
        are JSON values."""
        ...

    def end(self, reason: str) -> None:
        """End the run at this tick ('completed', or a reason of its own): what the robots
        did up to now is read, the tasks still open end as failed."""
        ...

    def set_closing_reason(self, reason: str) -> None:
        """The reason the tasks still open when the run ends are withdrawn with (from now
        on; 'run ended' until set)."""
        ...


class Referee(Protocol):
    """An experiment's part in the runner's loop, on the serving thread.

    The loop calls, in this order at every tick boundary: its fault schedule (the referee's
    `fault_actions` among the others), `before_tasks`, the introduction of due tasks,
    `after_tasks`, then its allocator's step. The auction hooks see every announcement,
    award and end of a task (as the runner reads them, at the next tick boundary).
    `experiments.referee_check.check_referee` drives one through a scripted run."""

    samplers: tuple[Sampler, ...]
    """Functions of (sim, t) the server runs between physics steps (ground truth)."""

    def bind(self, loop: RunHandle) -> None:
        """The run it watches, before the first tick."""
        ...

    def fault_actions(self) -> Mapping[str, Callable[[str, float], None]]:
        """Its own fault actions by name (none of the runner's): action(robot, now)."""
        ...

    def on_announce(self, task_id: str, name: str) -> None:
        """A task (of kind `name`) was put up for auction, by the user or by a robot."""
        ...

    def on_award(self, task_id: str, robot: str) -> None:
        """The task was awarded to `robot`."""
        ...

    def on_task_over(self, task_id: str) -> None:
        """The task ended, or went back to the team (its holder failed)."""
        ...

    def before_tasks(self, now: float) -> None:
        """At the tick boundary `now`, before due tasks are introduced."""
        ...

    def after_tasks(self, now: float) -> None:
        """At the tick boundary `now`, after due tasks are introduced."""
        ...


class NoReferee:
    """Nothing watches the run: it ends at its duration (or on an error)."""

    samplers: tuple[Sampler, ...] = ()

    def bind(self, loop: RunHandle) -> None:
        pass

    def fault_actions(self) -> Mapping[str, Callable[[str, float], None]]:
        return {}

    def on_announce(self, task_id: str, name: str) -> None:
        pass

    def on_award(self, task_id: str, robot: str) -> None:
        pass

    def on_task_over(self, task_id: str) -> None:
        pass

    def before_tasks(self, now: float) -> None:
        pass

    def after_tasks(self, now: float) -> None:
        pass


@dataclass(frozen=True)
class Verdict:
    """An experiment's judgement of a finished run: a message and the exit code it sets."""

    exit_code: int
    message: str


# -------------------------------------------------------------------------- experiments
class Experiment(Protocol):
    """What the runner asks of an experiment (`ExperimentBase` supplies the optional parts)."""

    @property
    def name(self) -> str: ...

    @property
    def world(self) -> str:
        """The world it runs in unless `--world` says otherwise."""
        ...

    @property
    def options(self) -> tuple[Option, ...]:
        """The command-line options it owns."""
        ...

    @property
    def task_kinds(self) -> tuple[str, ...]:
        """The task kinds its task source introduces (each registered)."""
        ...

    @property
    def supports(self) -> Supports: ...

    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        """The options, checked against the world (e.g. robot names resolved); raises
        `OptionError` naming the option."""
        ...

    def config(self, options: RunOptions) -> dict[str, Any]:
        """Its entries of config.json."""
        ...

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        """The user's tasks in time order (None: no more)."""
        ...

    def referee(self, spec: WorldSpec, options: RunOptions) -> Referee: ...

    def faults(self, options: RunOptions) -> list[Fault]:
        """The fault schedule entries of its own options."""
        ...

    def summary_sections(self, events: list[Mapping[str, Any]]) -> dict[str, Any]:
        """Its sections of summary.json."""
        ...

    def plots(self, events: list[Mapping[str, Any]], out_dir: Path) -> list[Path]:
        """Its PNGs in `out_dir` (beyond the plots of every run)."""
        ...

    def end_lines(self, referee: Referee) -> list[str]:
        """What it prints when the run has ended (before the summary)."""
        ...

    def verdict(self, summary: Mapping[str, Any]) -> Verdict | None:
        """A failure the summary shows that the run's own end reason does not."""
        ...

    def next_steps(self) -> list[str]:
        """Commands worth trying after a run."""
        ...


@dataclass(frozen=True)
class ExperimentBase:
    """Defaults for an experiment that adds nothing of its own in some places: subclass it
    and write `tasks` (and whatever else differs)."""

    name: str
    world: str
    steps: tuple[str, ...] = field(default=())
    options: tuple[Option, ...] = field(default=())
    task_kinds: tuple[str, ...] = field(default=())
    supports: Supports = field(default=Supports())

    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        return options

    def config(self, options: RunOptions) -> dict[str, Any]:
        return {}

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        raise NotImplementedError(f"experiment {self.name!r} has no task source")

    def referee(self, spec: WorldSpec, options: RunOptions) -> Referee:
        return NoReferee()

    def faults(self, options: RunOptions) -> list[Fault]:
        return []

    def summary_sections(self, events: list[Mapping[str, Any]]) -> dict[str, Any]:
        return {}

    def plots(self, events: list[Mapping[str, Any]], out_dir: Path) -> list[Path]:
        return []

    def end_lines(self, referee: Referee) -> list[str]:
        return []

    def verdict(self, summary: Mapping[str, Any]) -> Verdict | None:
        return None

    def next_steps(self) -> list[str]:
        return list(self.steps)


def labels(entries: Iterable[tuple[str, float]]) -> list[str]:
    """ROBOT@TIME labels of (robot, t_s) entries, as config.json lists them."""
    return [f"{r}@{t:g}s" for r, t in entries]

