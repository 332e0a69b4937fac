"""What an experiment is, to the runner: the interface a new experiment implements.

An experiment (`experiments.plugins`: one module each, and a line in the registry) says
which world it runs in by default, checks the options given for it, names its entries of
config.json, supplies the task source, its referee (what watches the run on the serving
thread and may end it: the boxpush goal watch), the faults of its own options, the sections
it adds to summary.json, its plots and what it prints at the end. Everything else (the
simulator, the Player server, the robot processes, the MURDOCH node, the recording) is the
same for every experiment and is put together by `experiments.run_cli.run_experiment`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from murdoch.allocators import ALLOCATORS

if TYPE_CHECKING:
    from experiments.run_loop import RunLoop
    from experiments.task_source import PlannedTask
    from worlds import WorldSpec


@dataclass(frozen=True)
class Fault:
    """One entry of the fault schedule: `action` on `robot` at simulation time `t_s`.

    Actions: kill, restart, switch-off, switch-on (boxpush), and for soak runs freeze, thaw
    (a robot's process stopped and continued, `hold_clock`), retire (switched off for good),
    charger-off, charger-on (`robot` names the charger) and burst (`count` tasks at once from
    the burst source)."""

    t_s: float
    action: str
    robot: str
    count: int = 0

    def label(self) -> str:
        return f"{self.robot}@{self.t_s:g}s"


ALLOCATOR_NAMES: tuple[str, ...] = tuple(ALLOCATORS)
"""The allocators a run's robots may use (`murdoch run --allocator`); MURDOCH by default."""


@dataclass(frozen=True)
class RunOptions:
    """The options of one run that experiments read (`murdoch run` and `murdoch soak`)."""

    duration_s: float
    seed: int
    task_interval_s: float = 240.0
    switch_offs: tuple[tuple[str, float], ...] = ()
    switch_ons: tuple[tuple[str, float], ...] = ()
    goal_radius_m: float | None = None
    goal_plan: Any = None
    """`experiments.boxpush.GoalPlan` (None: the goal stays where the world puts it)."""
    group_task_rate: float = 0.0
    """longterm: the fraction of the task stream that are group tasks (two robots at once)."""
    allocator: str = "murdoch"


Sampler = tuple[float, Callable[[Any, float], None]]
"""(period in simulated seconds, 0 = every step; a function of (sim, t)) run between steps."""


class Referee(Protocol):
    """An experiment's part in the runner's loop (`RunLoop`), on the serving thread.

    The loop calls, in this order at every tick boundary: its fault schedule (the referee's
    `fault_actions` among the others), `before_tasks`, the introduction of due tasks,
    `after_tasks`, then its MURDOCH node's step. The auction hooks see every announcement,
    award and end of a task."""

    samplers: tuple[Sampler, ...]

    def bind(self, loop: RunLoop) -> None: ...

    def fault_actions(self) -> Mapping[str, Callable[[str, float], None]]: ...

    def on_announce(self, task_id: str, name: str) -> None: ...

    def on_award(self, task_id: str, robot: str) -> None: ...

    def on_task_over(self, task_id: str) -> None: ...

    def before_tasks(self, now: float) -> None: ...

    def after_tasks(self, now: float) -> None: ...


class NoReferee:
    """Nothing watches the run: it ends at its duration (or on an error)."""

    samplers: tuple[Sampler, ...] = ()

    def bind(self, loop: RunLoop) -> None:
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


class Experiment(Protocol):
    @property
    def name(self) -> str: ...

    @property
    def world(self) -> str:
        """The world it runs in unless `--world` says otherwise."""
        ...

    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        """The options, checked against the world (robot names resolved); raises
        click.UsageError or click.BadParameter naming the option."""
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
    """Defaults for an experiment that adds nothing of its own in some places."""

    name: str
    world: str
    steps: tuple[str, ...] = field(default=())

    def config(self, options: RunOptions) -> dict[str, Any]:
        return {}

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
