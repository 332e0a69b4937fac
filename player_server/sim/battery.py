"""Battery model (pure): energy in joules, drained by a draw in watts, charged on a pad."""

from __future__ import annotations

from dataclasses import dataclass, field

from player_server.sim.readings import PowerState, fast_constructor
from worlds import PowerSpec

_make_state = fast_constructor(PowerState)


@dataclass
class Battery:
    """Mutable battery state owned by the simulation; ``update`` advances it by dt."""

    spec: PowerSpec
    joules: float
    watts: float = 0.0
    charging: bool = False
    flat: bool = False
    # the last reading and the (joules, watts, charging) it was made from
    _last: tuple[tuple[float, float, bool], PowerState] | None = field(
        default=None, repr=False, compare=False)

    @classmethod
    def full_as_specified(cls, spec: PowerSpec) -> Battery:
        b = cls(spec, spec.capacity_j * spec.initial_fraction)
        b.flat = b.fraction <= spec.flat_fraction
        return b

    @property
    def fraction(self) -> float:
        return self.joules / self.spec.capacity_j

    def draw_w(self, speed_fraction: float) -> float:
        s = self.spec
        return s.idle_w + s.moving_w * min(1.0, max(0.0, speed_fraction)) + s.sensor_w

    def update(self, dt_s: float, draw_w: float, charge_w: float) -> None:
        """Drain by draw_w and add charge_w (0 when off a charger) for dt_s seconds."""
        s = self.spec
        self.watts = draw_w
        self.charging = charge_w > 0.0
        self.joules = min(s.capacity_j, max(0.0, self.joules + (charge_w - draw_w) * dt_s))
        frac = self.fraction
        if self.flat:
            if frac >= s.resume_fraction and frac > s.flat_fraction:
                self.flat = False
        elif frac <= s.flat_fraction:
            self.flat = True

    def reading(self) -> PowerState:
        """The reading of the battery's state; the same object while that state is unchanged
        (a battery is read several times a tick)."""
        state = (self.joules, self.watts, self.charging)
        last = self._last
        if last is not None and last[0] == state:
            return last[1]
        s = self.spec
        frac = self.fraction
        reading = _make_state(s.volts_empty + (s.volts_full - s.volts_empty) * frac,
                              100.0 * frac, self.joules, self.watts, self.charging)
        self._last = (state, reading)
        return reading
