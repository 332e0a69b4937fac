"""Stage world files (Stage 4 syntax) read into the project's `WorldSpec`.

``load_stage_world("x.world")`` returns a `StageWorld` (the spec plus Stage's names for
rangers and fixed models); a malformed file raises `StageError` naming file:line, what was
expected and what was found. `syntax` parses, `tree` resolves definitions, `convert` and
`robots` map models onto the spec, `bitmap` turns floorplan images into wall boxes.
"""

from worlds.stage.convert import StageWorld, load_stage_world
from worlds.stage.robots import RangerRole
from worlds.stage.syntax import StageError, Where
from worlds.stage.tree import Warnings

__all__ = ["RangerRole", "StageError", "StageWorld", "Warnings", "Where", "load_stage_world"]
