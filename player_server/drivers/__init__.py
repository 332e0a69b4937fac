"""Device drivers: one adapter per Player interface between the simulator and messages.

``robot_drivers(sim, robot)`` builds the drivers a robot's device set declares;
``overhead_drivers(sim, world)`` those of the world's overhead camera.
"""

from player_server.drivers.base import ACK, NACK, Driver, Reply, Unsupported, ack
from player_server.drivers.registry import overhead_drivers, robot_drivers

__all__ = ["ACK", "NACK", "Driver", "Reply", "Unsupported", "ack", "overhead_drivers",
           "robot_drivers"]
