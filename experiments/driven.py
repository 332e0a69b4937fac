"""Metres driven, summed from successive recorded poses.

One rule for the summary's `distance_m`: the runner sums the poses as its recording writes
them, and `murdoch report` sums the same poses read back from ``run.mcap``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

TELEPORT_M = 2.0
"""A body that moved further than this between two recorded poses was placed, not driven."""


class PathLengths:
    """Metres each of `robots` drove: the sum of the steps between its successive positions,
    leaving out jumps of more than `TELEPORT_M` (a robot placed somewhere by the runner).
    Bodies that are not among `robots` are ignored."""

    def __init__(self, robots: Iterable[str]) -> None:
        self._names = set(robots)
        self._last: dict[str, tuple[float, float]] = {}
        self._total = dict.fromkeys(sorted(self._names), 0.0)

    def add(self, bodies: Mapping[str, Sequence[float]]) -> None:
        """One pose frame: body name -> (x, y, ...)."""
        last = self._last
        for name, pose in bodies.items():
            if name not in self._names:
                continue
            x, y = float(pose[0]), float(pose[1])
            if name in last:
                step = math.hypot(x - last[name][0], y - last[name][1])
                if step <= TELEPORT_M:
                    self._total[name] += step
            last[name] = (x, y)

    def by_robot(self) -> dict[str, float]:
        return {name: round(v, 3) for name, v in self._total.items()}

    def summary(self) -> dict[str, Any]:
        """summary.json's `distance_m`: metres per robot and in all."""
        by_robot = self.by_robot()
        return {"by_robot": by_robot, "total": round(sum(by_robot.values()), 3)}
