"""`optimal`: exact central assignment, the reference line on the public API (`murdoch.plugin`).

Whenever the team changes (a task arrives, a robot frees up, fails or leaves to charge), the
open tasks and the free robots are matched by a minimum-cost assignment (Hungarian method,
`scipy.optimize.linear_sum_assignment`): as many tasks as possible get a capable robot, and
among those matchings the one whose robots have the least distance to drive in all. A robot
that cannot do a task (missing subjects) is never matched to it.
"""

from __future__ import annotations

from collections.abc import Mapping

from murdoch.plugin import CentralAllocator, WorldView

UNABLE = 1e9
"""The cost of a pair that may not be matched: above any sum of real distances."""


class Optimal(CentralAllocator):
    """Open tasks to free capable robots by a minimum total distance assignment."""

    name = "optimal"
    summary = "central reference: open tasks to free robots, least total distance (exact)"

    def assign(self, world: WorldView) -> Mapping[str, str]:
        import numpy as np
        from scipy.optimize import linear_sum_assignment

        robots = [r for r in world.robots if r.free]
        tasks = list(world.tasks)
        if not robots or not tasks:
            return {}
        cost = np.array([[world.distance(r, t) if world.capable(r, t) else UNABLE
                          for r in robots] for t in tasks], dtype=float)
        rows, cols = linear_sum_assignment(cost)
        return {tasks[i].id: robots[j].name for i, j in zip(rows, cols, strict=True)
                if cost[i, j] < UNABLE}
