"""The long-term experiment: a stream of seeded tasks for a team that runs for hours.

Tasks of the four long-term kinds arrive at random (`task_source.longterm_tasks`, a mean
interval of `--task-interval`); with `--group-tasks RATE` that fraction of them are group
tasks instead (`experiments.group_tasks`: two robots watching one object from two sides),
drawn from a random source of their own so that the rest of the stream does not change.
Nothing referees the run, which ends at its duration; the runner's group coordinator judges
the group tasks (`experiments.group_coordinator`).
"""

from __future__ import annotations

import random
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import click

from experiments import boxpush as bp
from experiments.experiment import ExperimentBase, RunOptions
from experiments.group_tasks import group_summary, with_group_tasks
from experiments.task_source import PlannedTask, longterm_tasks
from worlds import WorldSpec

GROUP_SEED_OFFSET = 5
"""The group tasks' random source is seeded with the run's seed plus this."""


@dataclass(frozen=True)
class Longterm(ExperimentBase):
    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        from experiments.plugins.boxpush import resolve_switches

        options = resolve_switches(spec, options)
        if options.switch_offs or options.switch_ons or options.goal_plan not in (
                None, bp.GoalPlan()):
            raise click.UsageError("--switch-off/--switch-on/--goal-velocity/--retarget are "
                                   "for the boxpush experiment")
        if options.group_task_rate and not spec.objects:
            raise click.BadParameter(f"world {spec.name!r} has no object to watch",
                                     param_hint="--group-tasks")
        return options

    def config(self, options: RunOptions) -> dict[str, Any]:
        return {"group_task_rate": options.group_task_rate} if options.group_task_rate else {}

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        stream = longterm_tasks(spec, random.Random(options.seed + 1),
                                mean_interval_s=options.task_interval_s)
        if not options.group_task_rate:
            return stream
        return with_group_tasks(stream, spec, random.Random(options.seed + GROUP_SEED_OFFSET),
                                options.group_task_rate)

    def summary_sections(self, events: list[Mapping[str, Any]]) -> dict[str, Any]:
        return group_summary(events)


LONGTERM = Longterm("longterm", "longterm", steps=(
    "murdoch run longterm --until 1h --kill p3@30m --restart p3@45m",
    "murdoch run longterm --until 20m --meshcat   # watch it live in the browser",
    "murdoch run longterm --until 30m --group-tasks 0.3   # tasks for two robots at once",
    "murdoch run boxpush --until 10m        # the paper's box-pushing task",
))
