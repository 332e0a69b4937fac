"""World descriptions: TOML world files and their validated, frozen spec dataclasses.

``load_world(world_path("longterm"))`` returns a ``WorldSpec``; a malformed file raises
``WorldError`` naming the file, the key, what was expected and what was found.
"""

from worlds import spec
from worlds.colours import NAMED_COLOURS, colour_rgb01, parse_colour
from worlds.errors import WorldError
from worlds.loader import WORLDS_DIR, load_world, parse_world, world_path
from worlds.spec import *  # noqa: F403 (the names spec.__all__ declares)

__all__ = [
    "NAMED_COLOURS",
    "WORLDS_DIR",
    "WorldError",
    "colour_rgb01",
    "load_world",
    "parse_colour",
    "parse_world",
    "world_path",
]
__all__ += spec.__all__
