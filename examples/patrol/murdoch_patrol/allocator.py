"""``nearest-patroller``: each open patrol to the free robot nearest its first waypoint."""

from __future__ import annotations

import math
from collections.abc import Sequence

from murdoch_api import CentralAllocator, RobotView, TaskView, WorldView


class NearestPatroller(CentralAllocator):
    """Each open task to the nearest free capable robot (ties: by name)."""

    name = "nearest-patroller"
    summary = "each open task to the nearest free robot"

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        if task.place is None:
            return min(r.name for r in candidates)
        x, y = task.place
        return min(candidates,
                   key=lambda r: (math.hypot(r.pose[0] - x, r.pose[1] - y), r.name)).name
