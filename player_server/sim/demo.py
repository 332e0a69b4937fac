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
    charge_trips: dict[str, int] = field(default_factory=dict)


# Devices read every tick with ``sense_all`` (besides odometry): device -> Simulation method.
_READ_ALL = (("sonar", "sonar"), ("laser", "laser"), ("ranger", "ranger"),
             ("blobfinder", "blobs"), ("bumper", "bumpers"), ("gripper", "gripper"),
             ("ptz", "ptz"))


@dataclass(frozen=True)
class _Driven:
    name: str
    ranges: Callable[[str], np.ndarray]
    bearings: np.ndarray
    wanderer: Wanderer
    readers: tuple[Callable[[str], object], ...]  # the devices read before the ranges
    readers_after: tuple[Callable[[str], object], ...]  # and after them
    has_power: bool


class WanderDriver:
    """Each tick: every mobile robot reads its ranges (and, with ``sense_all``, every other
    device it has), decides with its own Wanderer, and commands its drive. A robot whose
    battery falls below ``low_percent`` drives to the nearest charger (by ground truth) and
    waits there until ``full_percent``."""

    def __init__(self, sim: Simulation, rng: np.random.Generator, sense_all: bool = False,
                 low_percent: float = 25.0, full_percent: float = 95.0):
        self.sim = sim
        self.sense_all = sense_all
        self.low_percent = low_percent
        self.full_percent = full_percent
        self._seeking: dict[str, tuple[float, float]] = {}
        self.stats = WanderStats()
        self.robots: list[_Driven] = []
        for spec in sim.spec.robots:
            if spec.devices.position2d is None:
                continue
            rb = range_bearings(spec)
            if rb is None:
                continue
            kind, bearings = rb
            wander_rng = np.random.default_rng(rng.integers(0, 2**63))
            d = spec.devices
            # every device in _READ_ALL's order; the range device the wanderer uses is read
            # once, for both
            devs = [dev for dev, _ in _READ_ALL if getattr(d, dev) is not None]
            readers = [getattr(sim, meth) for dev, meth in _READ_ALL if dev in devs]
            readers.append(sim.odometry)
            at = devs.index(kind)
            self.robots.append(_Driven(spec.name, getattr(sim, kind), bearings,
                                        Wanderer(wander_rng), tuple(readers[:at]),
                                        tuple(readers[at + 1:]), d.power is not None))
            self.stats.distance_m[spec.name] = 0.0
            self.stats.charging_s[spec.name] = 0.0
            self.stats.min_percent[spec.name] = 100.0
            self.stats.charge_trips[spec.name] = 0
        self._last = {r.name: sim.get_pose(r.name)[:2] for r in self.robots}

    def tick(self) -> None:
        sim = self.sim
        sense_all = self.sense_all
        seeking = self._seeking
        low = self.low_percent
        charger_goal = self._charger_goal
        power = sim.power
        set_velocity = sim.set_velocity
        for r in self.robots:
            name = r.name
            if sense_all:
                for read in r.readers:
                    read(name)
            ranges = r.ranges(name)
            if sense_all:
                for read in r.readers_after:
                    read(name)
            goal = None
            if r.has_power:
                percent = power(name).percent
                if percent < low or name in seeking:
                    goal = charger_goal(name, percent)
            if goal is None:
                v, w = r.wanderer.decide(r.bearings, ranges)
            else:
                x, y, yaw = sim.get_pose(name)
                gx, gy = goal
                bearing = math.atan2(gy - y, gx - x) - yaw
                bearing = math.atan2(math.sin(bearing), math.cos(bearing))
                v, w = r.wanderer.toward(bearing, math.hypot(gx - x, gy - y), r.bearings,
                                         ranges)
            set_velocity(name, v, w)
        sim.step()
        st = self.stats
        st.ticks += 1
        distance, charging, min_percent = st.distance_m, st.charging_s, st.min_percent
        last = self._last
        get_pose = sim.get_pose
        hypot = math.hypot
        for r in self.robots:
            name = r.name
            x, y, _ = get_pose(name)
            lx, ly = last[name]
            distance[name] += hypot(x - lx, y - ly)
            last[name] = (x, y)
            if r.has_power:
                p = power(name)
                if p.charging:
                    charging[name] += sim.interval_s
                if p.percent < min_percent[name]:
                    min_percent[name] = p.percent

    def _charger_goal(self, name: str, percent: float | None) -> tuple[float, float] | None:
        chargers = [c for c in self.sim.spec.chargers if c.rate_w > 0]  # (not the drains)
        if not chargers or percent is None:
            return None
        goal = self._seeking.get(name)
        if goal is not None and percent >= self.full_percent:
            del self._seeking[name]
            return None
        if goal is None and percent < self.low_percent:
            x, y, _ = self.sim.get_pose(name)
            c = min(chargers, key=lambda c: math.hypot(c.x - x, c.y - y))
            goal = self._seeking[name] = (c.x, c.y)
            self.stats.charge_trips[name] += 1
        return goal

    def run(self, ticks: int, on_progress: Callable[[int], None] | None = None,
            progress_every: int = 0) -> WanderStats:
        for i in range(ticks):
            self.tick()
            if on_progress is not None and progress_every and (i + 1) % progress_every == 0:
                on_progress(i + 1)
        return self.stats
