"""A reactive wanderer (pure decision, seeded): cruise, veer away from near obstacles, turn on
the spot when blocked. Used by the headless demo and the benchmark to keep robots moving."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from operator import itemgetter

import numpy as np
from numpy.typing import NDArray

from worlds import RobotSpec


def range_bearings(robot: RobotSpec) -> tuple[str, NDArray[np.float64]] | None:
    """The range device a wanderer should use (sonar, the cheapest; else laser; else ranger)
    and the bearing of each of its readings in the robot frame."""
    d = robot.devices
    if d.sonar is not None:
        return "sonar", np.array([m.yaw for m in d.sonar.poses])
    if d.laser is not None:
        return "laser", np.array(d.laser.angles_rad()) + d.laser.pose.yaw
    if d.ranger is not None:
        return "ranger", np.array(d.ranger.angles_rad()) + d.ranger.pose.yaw
    return None


@dataclass
class Wanderer:
    """Decides (v, w) from range readings; owns its random turn preference."""

    rng: np.random.Generator
    cruise_mps: float = 0.35
    turn_radps: float = 0.9
    stop_m: float = 0.55
    slow_m: float = 1.2
    _spin: float = 0.0
    _drift: float = 0.0
    _sector_key: int = -1
    _sector_cache: tuple = ()
    _sector_bearings: object = None
    _sector_getters: tuple[Callable[[list[float]], tuple[float, ...]] | None, ...] = ()

    def decide(self, bearings: NDArray[np.float64], ranges: NDArray[np.floating]) -> tuple[
        float, float
    ]:
        # `_minima`, written out: this runs for every robot every tick
        r = ranges.tolist()
        front, left, right = self._getters(bearings)
        front_min = math.inf if front is None else min(front(r))
        left_min = math.inf if left is None else min(left(r))
        right_min = math.inf if right is None else min(right(r))
        if front_min < self.stop_m:
            if self._spin == 0.0:
                self._spin = 1.0 if left_min >= right_min else -1.0
            return 0.0, self._spin * self.turn_radps
        self._spin = 0.0
        if self.rng.random() < 0.05:
            self._drift = float(self.rng.uniform(-0.4, 0.4))
        ease = (front_min - self.stop_m) / (self.slow_m - self.stop_m)
        v = self.cruise_mps * (1.0 if ease > 1.0 else 0.2 if ease < 0.2 else ease)
        w = self._drift
        if left_min < self.slow_m or right_min < self.slow_m:
            w += 0.6 if left_min > right_min else -0.6
        turn = self.turn_radps
        return v, (turn if w > turn else -turn if w < -turn else w)

    def toward(self, goal_bearing: float, goal_m: float, bearings: NDArray[np.float64],
               ranges: NDArray[np.floating]) -> tuple[float, float]:
        """Head for a goal at (bearing, distance) in the robot frame, avoiding obstacles
        ahead; stops on arrival (within 0.1 m)."""
        if goal_m < 0.1:
            return 0.0, 0.0
        front_min, left_min, right_min = self._minima(bearings, ranges)
        if front_min < self.stop_m and front_min < goal_m:
            if self._spin == 0.0:
                self._spin = 1.0 if left_min >= right_min else -1.0
            return 0.0, self._spin * self.turn_radps
        self._spin = 0.0
        w = max(-self.turn_radps, min(self.turn_radps, 1.5 * goal_bearing))
        v = min(self.cruise_mps, 0.5 * goal_m) * max(0.0, math.cos(goal_bearing))
        return v, w

    def _minima(self, bearings: NDArray[np.float64],
                ranges: NDArray[np.floating]) -> tuple[float, float, float]:
        """The nearest range in the front, left and right sectors (inf for an empty one),
        in plain Python: a handful of readings cost less than numpy calls on them."""
        r = ranges.tolist()
        front, left, right = self._getters(bearings)
        return (math.inf if front is None else min(front(r)),
                math.inf if left is None else min(left(r)),
                math.inf if right is None else min(right(r)))

    def _getters(self, bearings: NDArray[np.float64]) -> tuple[
        Callable[[list[float]], tuple[float, ...]] | None, ...
    ]:
        """Per sector, a getter of its readings as a tuple (None for an empty sector)."""
        if self._sector_key != id(bearings) or not self._sector_getters:
            # the first index once more makes a one-reading sector a tuple too
            self._sector_getters = tuple(
                itemgetter(*ix.tolist(), int(ix[0])) if ix.size else None
                for ix in self._sectors(bearings))
        return self._sector_getters

    def _sectors(self, bearings: NDArray[np.float64]) -> tuple[
        NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]
    ]:
        key = id(bearings)
        if self._sector_key != key:
            b = np.arctan2(np.sin(bearings), np.cos(bearings))
            self._sector_cache = (
                np.nonzero(np.abs(b) <= math.radians(35))[0],
                np.nonzero((b > math.radians(10)) & (b <= math.radians(100)))[0],
                np.nonzero((b < -math.radians(10)) & (b >= -math.radians(100)))[0],
            )
            self._sector_key = key
            self._sector_bearings = bearings  # keep the array (and so its id) alive
        return self._sector_cache
