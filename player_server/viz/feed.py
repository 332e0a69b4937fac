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
from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Protocol

from player_server.viz.scene import CHARGING, IDLE


class FedView(Protocol):
    """The part of `player_server.viz.live.LiveView` the feed uses."""

    def offer(self, snapshot: Any) -> None: ...

    def offer_scans(self, scans: Mapping[str, Any]) -> None: ...

    def set_battery(self, robot: str, percent: float) -> None: ...

    def set_robot(self, robot: str, state: str, label: str = "") -> None: ...


@dataclass(eq=False)
class LiveFeed:
    """Feeds `view` at most once every `period_s` of `wall_clock` time; `frames` counts the
    hand-overs."""

    view: FedView
    _: KW_ONLY
    wall_clock: Callable[[], float]
    period_s: float = 0.1
    power_robots: tuple[str, ...] = ()
    scan_robots: tuple[str, ...] = ()
    states_from_power: bool = False
    frames: int = field(default=0, init=False)
    _next_wall: float = field(default=-1.0, init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.period_s > 0:
            raise ValueError(f"the live feed's period must be positive, got {self.period_s}")

    def after_step(self, sim: Any) -> None:
        now = self.wall_clock()
        if now < self._next_wall:
            return
        self._next_wall = now + self.period_s
        self.frames += 1
        view = self.view
        # battery and states first: the snapshot (which carries the clock) closes the frame
        for robot in self.power_robots:
            power = sim.power(robot)
            view.set_battery(robot, float(power.percent))
            if self.states_from_power:
                view.set_robot(robot, CHARGING if power.charging else IDLE)
        if self.scan_robots:
            laser = sim.laser
            view.offer_scans({r: laser(r).tolist() for r in self.scan_robots})
        view.offer(sim.snapshot())
