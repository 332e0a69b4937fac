"""Building endpoints (robot -> port -> drivers) for a world and its simulator."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from player_server.drivers.registry import overhead_drivers, robot_drivers
from player_server.server.endpoint import Endpoint

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds import WorldSpec



def world_endpoints(world: WorldSpec, sim: SimPort, base_port: int, *,
                    allow_world_control: bool = False) -> list[Endpoint]:
    """One endpoint per robot on base_port, base_port + 1, ...; the overhead camera last.

    With ``base_port`` 0 every endpoint gets an ephemeral port. Network clients may pause,
    reset and move bodies through simulation:0 only with ``allow_world_control``.
    """
    endpoints: list[Endpoint] = []

    def port(i: int) -> int:
        return 0 if base_port == 0 else base_port + i

    for i, robot in enumerate(world.robots):
        drivers = robot_drivers(sim, robot, world_control=allow_world_control)
        endpoints.append(Endpoint(robot.name, drivers, requested_port=port(i),
                                  mobile=bool(robot.mobile)))
    if world.overhead_camera is not None:
        drivers = overhead_drivers(sim, world, world_control=allow_world_control)
        endpoints.append(Endpoint(world.overhead_camera.name, drivers,
                                  requested_port=port(len(world.robots)), mobile=False))
    return endpoints


def all_drivers(endpoints: list[Endpoint]) -> list[Any]:
    return [d for ep in endpoints for d in ep.drivers.values()]
