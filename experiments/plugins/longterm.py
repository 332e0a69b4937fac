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

from experiments.group_tasks import group_summary, with_group_tasks
from experiments.plugin import (
    ExperimentBase,
    Option,
    OptionError,
    RunOptions,
    Supports,
    fraction,
)
from experiments.task_source import LONGTERM_KINDS, PlannedTask, longterm_tasks
from worlds import WorldSpec

GROUP_SEED_OFFSET = 5
"""The group tasks' random source is seeded with the run's seed plus this."""

GROUP_TASKS = Option(
    "--group-tasks", "the fraction of tasks that are group tasks, each needing two robots at "
    "once (watch one object from two sides).", type=fraction, default=0.0, metavar="RATE")


@dataclass(frozen=True)
class Longterm(ExperimentBase):
    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        if options.get("group_tasks", 0.0) and not spec.objects:
            raise OptionError("--group-tasks", f"world {spec.name!r} has no object to watch")
        return options

    def config(self, options: RunOptions) -> dict[str, Any]:
        rate = options.get("group_tasks", 0.0)
        return {"group_task_rate": rate} if rate else {}

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        stream = longterm_tasks(spec, random.Random(options.seed + 1),
                                mean_interval_s=options.task_interval_s)
        rate = options.get("group_tasks", 0.0)
        if not rate:
            return stream
        return with_group_tasks(stream, spec, random.Random(options.seed + GROUP_SEED_OFFSET),
                                rate)

    def summary_sections(self, events: list[Mapping[str, Any]]) -> dict[str, Any]:
        return group_summary(events)


LONGTERM = Longterm(
    "longterm", "longterm", steps=(
        "murdoch run longterm --until 1h --kill p3@30m --restart p3@45m",
        "murdoch run longterm --until 20m --meshcat   # watch it live in the browser",
        "murdoch run longterm --until 30m --group-tasks 0.3   # tasks for two robots at once",
        "murdoch run boxpush --until 10m        # the paper's box-pushing task",
    ),
    options=(GROUP_TASKS,),
    task_kinds=(*LONGTERM_KINDS, "watch-object-side"),
    supports=Supports(soak=True, compare=True),
)
