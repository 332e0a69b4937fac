"""The simulated world: PyBullet physics, 2-D ray-cast and rendered sensors, batteries.

The only package that imports pybullet; it knows nothing of Player. ``Simulation(spec)`` owns
one PyBullet DIRECT client; readings are plain values and the frozen dataclasses below.
"""

from player_server.sim import readings
from player_server.sim.readings import *  # noqa: F403 (the names readings.__all__ declares)
from player_server.sim.simulation import Simulation, Timings

__all__ = [
    "Simulation",
    "Timings",
]
__all__ += readings.__all__
