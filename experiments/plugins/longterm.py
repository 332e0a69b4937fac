"""The long-term experiment: a stream of seeded tasks for a team that runs for hours.

Tasks of the four long-term kinds arrive at random (`task_source.longterm_tasks`, a mean
interval of `--task-interval`); nothing referees the run, which ends at its duration.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from dataclasses import dataclass

import click

from experiments import boxpush as bp
from experiments.experiment import ExperimentBase, RunOptions
from experiments.task_source import PlannedTask, longterm_tasks
from worlds import WorldSpec


@dataclass(frozen=True)
class Longterm(ExperimentBase):
    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        from experiments.plugins.boxpush import resolve_switches

        options = resolve_switches(spec, options)
        if options.switch_offs or options.switch_ons or options.goal_plan not in (
                None, bp.GoalPlan()):
            raise click.UsageError("--switch-off/--switch-on/--goal-velocity/--retarget are "
                                   "for the boxpush experiment")
        return options

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        return longterm_tasks(spec, random.Random(options.seed + 1),
                              mean_interval_s=options.task_interval_s)


LONGTERM = Longterm("longterm", "longterm", steps=(
    "murdoch run longterm --until 1h --kill p3@30m --restart p3@45m",
    "murdoch run longterm --until 20m --meshcat   # watch it live in the browser",
    "murdoch run boxpush --until 10m        # the paper's box-pushing task",
))
