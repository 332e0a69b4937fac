"""Drive every robot of a Simulation with a Wanderer (the headless demo and the benchmark)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from player_server.sim.simulation import Simulation
from player_server.sim.wander import Wanderer, range_bearings


@dataclass
class WanderStats:
    ticks: int = 0
    distance_m: dict[str, float] = field(default_factory=dict)
    charging_s: dict[str, float] = field(default_factory=dict)
    min_percent: dict[str, float] = field(default_factory=dict)


class WanderDriver:
    """Each tick: every mobile robot reads its ranges (and, with ``sense_all``, every other
    device it has), decides with its own Wanderer, and commands its drive."""

    def __init__(self, sim: Simulation, rng: np.random.Generator, sense_all: bool = False):
        self.sim = sim
        self.sense_all = sense_all
        self.stats = WanderStats()
        self._robots: list[tuple[str, str, np.ndarray, Wanderer]] = []
        for spec in sim.spec.robots:
            if spec.devices.position2d is None:
                continue
            rb = range_bearings(spec)
            if rb is None:
                continue
            kind, bearings = rb
            wander_rng = np.random.default_rng(rng.integers(0, 2**63))
            self._robots.append((spec.name, kind, bearings, Wanderer(wander_rng)))
            self.stats.distance_m[spec.name] = 0.0
            self.stats.charging_s[spec.name] = 0.0
            self.stats.min_percent[spec.name] = 100.0
        self._last = {n: sim.get_pose(n)[:2] for n, *_ in self._robots}

    def _sense_everything(self, name: str) -> None:
        sim = self.sim
        d = sim.spec.robot(name).devices
        if d.sonar is not None:
            sim.sonar(name)
        if d.laser is not None:
            sim.laser(name)
        if d.ranger is not None:
            sim.ranger(name)
        if d.blobfinder is not None:
            sim.blobs(name)
        if d.bumper is not None:
            sim.bumpers(name)
        if d.gripper is not None:
            sim.gripper(name)
        if d.ptz is not None:
            sim.ptz(name)
        sim.odometry(name)

    def tick(self) -> None:
        sim = self.sim
        for name, kind, bearings, wanderer in self._robots:
            if self.sense_all:
                self._sense_everything(name)
            ranges = getattr(sim, kind)(name)
            v, w = wanderer.decide(bearings, ranges)
            sim.set_velocity(name, v, w)
        sim.step()
        st = self.stats
        st.ticks += 1
        for name, *_ in self._robots:
            x, y, _ = sim.get_pose(name)
            lx, ly = self._last[name]
            st.distance_m[name] += math.hypot(x - lx, y - ly)
            self._last[name] = (x, y)
            if sim.spec.robot(name).devices.power is not None:
                p = sim.power(name)
                if p.charging:
                    st.charging_s[name] += sim.interval_s
                st.min_percent[name] = min(st.min_percent[name], p.percent)

    def run(self, ticks: int, on_progress: Callable[[int], None] | None = None,
            progress_every: int = 0) -> WanderStats:
        for i in range(ticks):
            self.tick()
            if on_progress is not None and progress_every and (i + 1) % progress_every == 0:
                on_progress(i + 1)
        return self.stats
