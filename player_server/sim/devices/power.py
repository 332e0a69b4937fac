"""Power: each robot's battery, drained by its drive and charged on a charging pad."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from player_server.sim.battery import Battery
from player_server.sim.contact import Rect, polygon_touches, rects_touch
from player_server.sim.readings import PowerState

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState
    from player_server.sim.devices.world import DeviceWorld


class PowerModel:
    kinds: ClassVar[tuple[str, ...]] = ("power",)
    order: ClassVar[int] = 20
    ticking: ClassVar[bool] = True

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world
        self.chargers_off: set[str] = set()  # kept across rebuilds; the world's `reset` clears it

    def build(self) -> None:
        for st in self.world.robots:
            spec = st.spec.devices.power
            if spec is not None:
                st.battery = Battery.full_as_specified(spec)

    def advance(self, dt: float) -> None:
        # the pads switched on (the same for every robot this tick): centre, radius squared,
        # rate; the models with a footprint apart
        on = [c for c in self.world.spec.chargers if c.name not in self.chargers_off]
        pads = [(c.x, c.y, c.radius_m ** 2, c.rate_w) for c in on if c.size_x_m <= 0.0]
        models = [((c.x, c.y, c.size_x_m / 2, c.size_y_m / 2, c.yaw), c.rate_w, c.take_w)
                  for c in on if c.size_x_m > 0.0]
        for st in self.world.robots:
            b = st.battery
            if b is None:
                continue
            p2d = st.spec.devices.position2d
            frac = 0.0
            if p2d is not None:
                frac = 0.5 * (abs(st.v) / p2d.max_speed_mps + abs(st.w) / p2d.max_yaw_rate_radps)
            charge = 0.0
            x, y = st.x, st.y
            for cx, cy, r2, rate in pads:
                if (x - cx) ** 2 + (y - cy) ** 2 <= r2:
                    charge = rate
                    break
            taken = 0.0
            if models:
                charge, taken = _contact(st, models, charge)
            b.update(dt, b.draw_w(frac) + taken, charge)

    def power(self, robot: str) -> PowerState:
        st = self.world.device(robot, "power")
        assert st.battery is not None
        return st.battery.reading()

    def set_battery(self, robot: str, fraction: float) -> None:
        st = self.world.device(robot, "power")
        assert st.battery is not None
        if not 0.0 <= fraction <= 1.0:
            raise ValueError("fraction must be within [0, 1]")
        b = st.battery
        b.joules = b.spec.capacity_j * fraction
        b.flat = b.fraction <= b.spec.flat_fraction

    def set_charger_enabled(self, charger: str, enabled: bool) -> None:
        if charger not in {c.name for c in self.world.spec.chargers}:
            raise KeyError(f"no charger named {charger!r}")
        if enabled:
            self.chargers_off.discard(charger)
        else:
            self.chargers_off.add(charger)

    def charger_enabled(self, charger: str) -> bool:
        return charger not in self.chargers_off


def _contact(st: RobotState, models: list[tuple[Rect, float, float]],
             charge: float) -> tuple[float, float]:
    """(watts given, watts taken) by the models whose footprint the robot's body touches:
    the first giver's rate (unless a pad already gives), every taker's sum."""
    body = st.spec.body
    c, s = math.cos(st.yaw), math.sin(st.yaw)
    rect = (st.x + body.offset_x_m * c, st.y + body.offset_x_m * s, body.length_m / 2,
            body.width_m / 2, st.yaw)
    outline = [(rect[0] + c * px - s * py, rect[1] + s * px + c * py)
               for px, py in body.outline]
    taken = 0.0
    for footprint, give, take in models:
        if polygon_touches(outline, footprint) if outline else rects_touch(rect, footprint):
            if charge <= 0.0 and give > 0.0:
                charge = give
            taken += take
    return charge, taken
