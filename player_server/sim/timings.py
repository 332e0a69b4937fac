"""Where a simulated tick's wall time goes, for benchmarks."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Timings:
    """Cumulative wall seconds spent per activity (for benchmarks), measured by the clock."""

    physics_s: float = 0.0
    ranges_s: float = 0.0
    blobs_s: float = 0.0
    battery_s: float = 0.0
    other_s: float = 0.0

    def as_dict(self) -> dict[str, float]:
        return dict(self.__dict__)
