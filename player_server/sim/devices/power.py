"""Power: each robot's battery, drained by its drive and charged on a charging pad."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from player_server.sim.battery import Battery
from player_server.sim.readings import PowerState

if TYPE_CHECKING:
    from player_server.sim.simulation import Simulation, _Robot


class PowerModel:
    kinds: ClassVar[tuple[str, ...]] = ("power",)
    ticking: ClassVar[bool] = True

    def __init__(self, world: Simulation) -> None:
        self.world = world
        self.chargers_off: set[str] = set()  # kept across rebuilds; `Simulation.reset` clears it

    def build(self) -> None:
        for st in self.world._robots:
            spec = st.spec.devices.power
            if spec is not None:
                st.battery = Battery.full_as_specified(spec)

    def advance(self, dt: float) -> None:
        for st in self.world._robots:
            if st.battery is not None:
                self._advance_battery(st, dt)

    def _advance_battery(self, st: _Robot, dt: float) -> None:
        b = st.battery
        assert b is not None
        p2d = st.spec.devices.position2d
        frac = 0.0
        if p2d is not None:
            frac = 0.5 * (abs(st.v) / p2d.max_speed_mps + abs(st.w) / p2d.max_yaw_rate_radps)
        charge = 0.0
        for c in self.world.spec.chargers:
            if c.name in self.chargers_off:
                continue
            if (st.x - c.x) ** 2 + (st.y - c.y) ** 2 <= c.radius_m ** 2:
                charge = c.rate_w
                break
        b.update(dt, b.draw_w(frac), charge)

    def power(self, robot: str) -> PowerState:
        st = self.world._device(robot, "power")
        assert st.battery is not None
        return st.battery.reading()

    def set_battery(self, robot: str, fraction: float) -> None:
        st = self.world._device(robot, "power")
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
