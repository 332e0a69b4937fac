"""Reading what `player-server` serves from a Stage world or a Player configuration file,
and writing the start-up table as JSON for scripts."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

from player_server.protocol.constants import DEFAULT_PORT

if TYPE_CHECKING:
    from player_server.server.endpoint import Endpoint
    from worlds.player_plan import ServePlan
    from worlds.stage import StageWorld


def is_stage_source(path: str) -> bool:
    return Path(path).suffix in (".world", ".cfg")


def load_stage_source(path: str, port: int) -> tuple[StageWorld, ServePlan]:
    """The world and the addresses to serve; StageError (file:line, expected, found)."""
    from worlds.player_cfg import load_player_cfg
    from worlds.player_plan import plan_from_cfg, plan_from_world
    from worlds.stage import Warnings, load_stage_world

    base = port or DEFAULT_PORT
    warnings = Warnings()
    if Path(path).suffix == ".world":
        world = load_stage_world(path, warnings=warnings)
        return world, plan_from_world(world, base)
    from worlds.player_plan import worldfile_of

    cfg = load_player_cfg(path, base, warnings)
    world = load_stage_world(worldfile_of(cfg), warnings=warnings)
    return world, plan_from_cfg(cfg, world, warnings)


def table_json(endpoints: list[Endpoint], plan_ports: list[int] | None = None) -> str:
    """[{"name", "port", "devices", "configured_port"}, ...]: what the table says."""
    rows = []
    for i, ep in enumerate(endpoints):
        row: dict[str, object] = {"name": ep.name, "port": ep.port,
                                  "devices": ep.device_names()}
        if plan_ports is not None:
            row["configured_port"] = plan_ports[i]
        rows.append(row)
    return json.dumps({"endpoints": rows}, indent=2) + "\n"


def write_atomically(path: Path, text: str) -> None:
    """Readers never see a half-written file: written beside it, then renamed over it."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
