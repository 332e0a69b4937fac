"""Pure-Python Player 3.x client: ``PlayerClient`` and one proxy per interface.

Depends only on ``player_server.protocol`` (and the standard library).
"""

from player_server.client.connection import PlayerClient
from player_server.client.errors import (
    PlayerConnectionClosed,
    PlayerConnectionError,
    PlayerError,
    PlayerNack,
    PlayerTimeout,
)
from player_server.client.proxies import (
    PROXIES,
    BlobfinderProxy,
    BumperProxy,
    CameraProxy,
    FiducialProxy,
    GripperProxy,
    ImuProxy,
    LaserProxy,
    OpaqueProxy,
    Position2dProxy,
    PowerProxy,
    PtzProxy,
    RangerProxy,
    ScanBody,
    SimulationProxy,
    SonarProxy,
)
from player_server.client.proxy import Proxy

__all__ = [
    "PROXIES",
    "BlobfinderProxy",
    "BumperProxy",
    "CameraProxy",
    "FiducialProxy",
    "GripperProxy",
    "ImuProxy",
    "LaserProxy",
    "OpaqueProxy",
    "PlayerClient",
    "PlayerConnectionClosed",
    "PlayerConnectionError",
    "PlayerError",
    "PlayerNack",
    "PlayerTimeout",
    "Position2dProxy",
    "PowerProxy",
    "Proxy",
    "PtzProxy",
    "RangerProxy",
    "ScanBody",
    "SimulationProxy",
    "SonarProxy",
]
