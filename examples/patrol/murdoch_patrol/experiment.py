"""The ``patrol`` experiment: patrol routes of a few waypoints arrive at random."""

from __future__ import annotations

import random
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from murdoch_api import ExperimentBase, Option, OptionError, PlannedTask, RunOptions, Supports

MARGIN_M = 1.0
"""Waypoints keep this far from the arena's walls."""


@dataclass(frozen=True)
class Patrol(ExperimentBase):
    def check(self, spec: Any, options: RunOptions) -> RunOptions:
        if options.get("waypoints_per_route") < 1:
            raise OptionError("--waypoints-per-route", "expected at least 1")
        return options

    def config(self, options: RunOptions) -> dict[str, Any]:
        return {"waypoints_per_route": options.get("waypoints_per_route"),
                "patrol_s": options.get("patrol_s")}

    def tasks(self, spec: Any, options: RunOptions) -> Iterator[PlannedTask | None]:
        rng = random.Random(options.seed + 3)
        half_x = spec.arena.size_x_m / 2 - MARGIN_M
        half_y = spec.arena.size_y_m / 2 - MARGIN_M
        t = 5.0
        while True:
            points = [(round(rng.uniform(-half_x, half_x), 2),
                       round(rng.uniform(-half_y, half_y), 2))
                      for _ in range(options.get("waypoints_per_route"))]
            yield PlannedTask(round(t, 3), "patrol-waypoints", {
                "waypoints": ";".join(f"{x},{y}" for x, y in points),
                "x": points[0][0], "y": points[0][1],
                "duration_s": float(options.get("patrol_s")),
            })
            t += rng.expovariate(1.0 / options.task_interval_s)


PATROL_EXPERIMENT = Patrol(
    "patrol", "longterm",
    steps=("murdoch run patrol --allocator nearest-patroller --until 20m",),
    options=(
        Option("--waypoints-per-route", "waypoints in each patrol route.", type=int,
               default=3),
        Option("--patrol-s", "simulated seconds each patrol lasts.", type=float,
               default=90.0),
    ),
    task_kinds=("patrol-waypoints",),
    supports=Supports(soak=True, compare=True),
)
