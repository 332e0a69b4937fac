"""Endpoints for a Stage world served as a Player configuration (or a world) says.

Each port of the plan becomes one endpoint holding exactly the devices bound to it, for one
model or several. A robot's laser served both as `ranger:N` and (through `rangertolaser`) as
`laser:M` shares one configuration, as in Player.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from player_server.drivers.base import Driver
from player_server.drivers.ranging import LaserDriver, RangerDriver, SonarRangerDriver
from player_server.drivers.registry import driver_class
from player_server.drivers.scan_config import ConfiguredScan
from player_server.drivers.simulation import SimulationDriver
from player_server.protocol.constants import interface_code
from player_server.server.endpoint import Endpoint

if TYPE_CHECKING:
    from player_server.drivers.sim_port import SimPort
    from worlds.player_plan import Binding, ServePlan
    from worlds.stage import StageWorld


def plan_endpoints(plan: ServePlan, world: StageWorld, sim: SimPort, *,
                   allow_world_control: bool = False, ephemeral: bool = False
                   ) -> list[Endpoint]:
    """One endpoint per port of the plan, in the order the ports first appear; with
    ``ephemeral`` every endpoint asks for a free port instead of the plan's."""
    scans: dict[str, ConfiguredScan] = {}
    interval_s = float(world.spec.sim.interval_sim_s)

    def make(b: Binding) -> Driver:
        index = b.address.index
        if b.device == "simulation":
            return SimulationDriver(sim, index, world_control=allow_world_control,
                                    fixed=world.fixed)
        robot = world.spec.robot(b.model)
        if b.device in ("laser", "laser_ranger"):
            laser = robot.devices.laser
            scan = scans.setdefault(b.model, ConfiguredScan(laser, interval_s))
            if b.device == "laser":
                return LaserDriver(sim, robot, index, scan=scan)
            return RangerDriver(sim, robot, index, source="laser", scan=scan)
        if b.device == "sonar_ranger":
            return SonarRangerDriver(sim, robot, index)
        return driver_class(b.device)(sim, robot, index)

    endpoints: list[Endpoint] = []
    for port in plan.ports():
        here = [b for b in plan.bindings if b.address.port == port]
        drivers = {(interface_code(b.address.interface), b.address.index): make(b)
                   for b in here}
        models = list(dict.fromkeys(b.model for b in here if b.model))
        endpoints.append(Endpoint("+".join(models) or f"simulation@{port}", drivers,
                                  requested_port=0 if ephemeral else port,
                                  mobile=any(b.device == "position2d" for b in here)))
    return endpoints
