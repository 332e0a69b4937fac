"""Infrared proximity sensors: short beams fanned out from the robot's body.

``[robots.ir]`` gives a robot `count` beams, evenly spread over `fov` around straight ahead,
at height `z`; each reports how far its beam runs from the body's surface before it meets a
body (a wall, a box, another robot), up to `max_range` (the reading when nothing is there).
The simulator's `player_server.sim.devices.ir` measures them; Player serves them as
``ranger:1`` (`player_server.drivers.ir`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from worlds.device_kinds import declare_device
from worlds.params import param


@declare_device("ir", doc="infrared proximity beams from the body's surface", draw_w=0.5)
@dataclass(frozen=True)
class IrSpec:
    """A fan of infrared proximity beams (an e-puck-like front arc by default)."""

    count: int = param(5, "how many beams", kind="integer", min=1)
    fov_rad: float = param(math.radians(180.0), "the fan the beams spread over, centred ahead",
                           kind="angle", min=1e-3, max=2 * math.pi)
    z_m: float = param(0.1, "height of the beams above the floor (m)", min=0.0)
    max_range_m: float = param(0.3, "the longest range, reported when nothing is seen (m)",
                               positive=True)

    def bearings_rad(self) -> tuple[float, ...]:
        """Each beam's direction relative to the robot's heading, right to left."""
        step = self.fov_rad / self.count
        return tuple(-self.fov_rad / 2 + (i + 0.5) * step for i in range(self.count))


def surface_distance(bearing_rad: float, half_length_m: float, half_width_m: float) -> float:
    """How far from the centre of a body box a beam with this bearing leaves it."""
    c, s = abs(math.cos(bearing_rad)), abs(math.sin(bearing_rad))
    along = half_length_m / c if c > 1e-12 else math.inf
    across = half_width_m / s if s > 1e-12 else math.inf
    return min(along, across)
