"""What the live view is fed from a stepping simulation: the one feeder of every command.

`LiveFeed.after_step(sim)` runs on the thread that steps the simulation, after each step. At
most once every `period_s` of wall time it hands the live view the newest snapshot (poses and
the simulation clock), the battery level of every robot with a power device, the laser ranges
of the robots asked for and, when `states_from_power` (a world with no team to report states),
whether each robot is charging. Each hand-over is a lock and an assignment in the view; the
simulation never waits for the viewer.

`murdoch run`, `murdoch soak`, every experiment (through `experiments.observe.ObservedSim`) and
``python -m player_server.viz`` all feed the view through this class.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

from player_server.viz.scene import CHARGING, IDLE


class FedView(Protocol):
    """The part of `player_server.viz.live.LiveView` the feed uses."""

    def offer(self, snapshot: Any) -> None: ...

    def offer_scans(self, scans: Mapping[str, Any]) -> None: ...

    def set_battery(self, robot: str, percent: float) -> None: ...

    def set_robot(self, robot: str, state: str, label: str = "") -> None: ...


class LiveFeed:
    def __init__(
        self,
        view: FedView,
        *,
        wall_clock: Callable[[], float],
        period_s: float = 0.1,
        power_robots: tuple[str, ...] = (),
        scan_robots: tuple[str, ...] = (),
        states_from_power: bool = False,
    ) -> None:
        if not period_s > 0:
            raise ValueError(f"the live feed's period must be positive, got {period_s}")
        self._view = view
        self._clock = wall_clock
        self._period_s = period_s
        self._power = power_robots
        self._scans = scan_robots
        self._states_from_power = states_from_power
        self._next_wall = -1.0
        self.frames = 0

    def after_step(self, sim: Any) -> None:
        now = self._clock()
        if now < self._next_wall:
            return
        self._next_wall = now + self._period_s
        self.frames += 1
        view = self._view
        # battery and states first: the snapshot (which carries the clock) closes the frame
        for robot in self._power:
            power = sim.power(robot)
            view.set_battery(robot, float(power.percent))
            if self._states_from_power:
                view.set_robot(robot, CHARGING if power.charging else IDLE)
        if self._scans:
            laser = sim.laser
            view.offer_scans({r: laser(r).tolist() for r in self._scans})
        view.offer(sim.snapshot())
