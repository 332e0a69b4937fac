"""The simulated world: PyBullet physics, 2-D ray-cast and rendered sensors, batteries.

The only package that imports pybullet; it knows nothing of Player. ``Simulation(spec)`` owns
one PyBullet DIRECT client; readings are plain values and the frozen dataclasses below.

``Simulation`` and ``Timings`` are loaded when first asked for, so that a process that only
reads readings (the recording's writer unpickling them) does not load PyBullet and the
compiled sensing kernels.
"""

from typing import TYPE_CHECKING, Any

from player_server.sim import readings
from player_server.sim.readings import *  # noqa: F403 (the names readings.__all__ declares)

if TYPE_CHECKING:
    from player_server.sim.simulation import Simulation, Timings

__all__ = [
    "Simulation",
    "Timings",
]
__all__ += readings.__all__


def __getattr__(name: str) -> Any:
    if name in ("Simulation", "Timings"):
        from player_server.sim import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
