"""The Player device server: a sans-IO dispatch core, a TCP front end, the serving loop.

``PlayerServer(sim, world_endpoints(world, sim, base_port), ...)`` serves a world;
``python -m player_server.server WORLD.toml`` (``player-server``) does it from the shell.
"""

from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig, ServerCore, Session
from player_server.server.endpoint import Endpoint
from player_server.server.runner import PlayerServer

__all__ = ["CoreConfig", "Endpoint", "PlayerServer", "ServerCore", "Session", "world_endpoints"]
