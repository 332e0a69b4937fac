"""`greedy`: sequential greedy allocation, a baseline on the public API (`murdoch.plugin`).

Whenever the team changes (a task arrives, a robot frees up, fails or leaves to charge), the
open tasks are taken in arrival order and each goes to the nearest free robot that offers
every subject it needs (ties to the smaller name); a robot takes one task per decision.
"""

from __future__ import annotations

from collections.abc import Sequence

from murdoch.plugin import CentralAllocator, RobotView, TaskView, WorldView


class Greedy(CentralAllocator):
    """Each open task, in arrival order, to the nearest capable free robot."""

    name = "greedy"
    summary = "central baseline: each open task, in arrival order, to the nearest free robot"

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        best = min(candidates, key=lambda r: (world.distance(r, task), r.name))
        return best.name
