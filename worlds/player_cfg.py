"""Player configuration files (`.cfg`): driver blocks and their device addresses.

``load_player_cfg("x.cfg", default_port=6665)`` returns the `driver` blocks in file order.
An address is ``[key:][host:][port:]interface:index``; a missing port is the default port.
The syntax is Stage's (`worlds.stage.syntax`); a malformed file raises `StageError`
(file:line, expected, found). What a driver means is the server's business, not this module's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from worlds.stage.syntax import Entity, Prop, StageError, Where, parse_file
from worlds.stage.tree import Warnings

__all__ = ["Address", "DriverBlock", "PlayerConfig", "load_player_cfg", "parse_address"]

#: keys of a stage driver block that are read (others are warned about)
STAGE_KEYS = frozenset({"name", "plugin", "provides", "requires", "model", "worldfile",
                        "usegui", "alwayson"})


@dataclass(frozen=True)
class Address:
    port: int
    interface: str
    index: int

    def __str__(self) -> str:
        return f"{self.port}:{self.interface}:{self.index}"


@dataclass(frozen=True)
class DriverBlock:
    name: str
    provides: tuple[Address, ...]
    requires: tuple[Address, ...]
    model: str | None
    worldfile: Path | None  # resolved against the .cfg's directory
    plugin: str
    where: Where


@dataclass(frozen=True)
class PlayerConfig:
    file: Path
    drivers: tuple[DriverBlock, ...]
    warnings: tuple[str, ...]


def parse_address(text: str, default_port: int, where: Where) -> Address:
    parts = text.split(":")
    if len(parts) < 2 or len(parts) > 5:
        raise StageError(where, "an address [port:]interface:index", repr(text))
    interface, index = parts[-2], parts[-1]
    port_text = parts[-3] if len(parts) >= 3 else ""
    if not interface or not interface.replace("_", "").isalnum() or not index.isdigit():
        raise StageError(where, "an address [port:]interface:index", repr(text))
    if port_text and not port_text.isdigit():
        raise StageError(where, "a port number in the address", repr(text))
    host = parts[-4] if len(parts) >= 4 else ""
    if host not in ("", "localhost", "127.0.0.1"):
        raise StageError(where, "an address on this host", repr(text))
    port = int(port_text) if port_text else default_port
    if not 0 <= port <= 65535:
        raise StageError(where, "a port in 0..65535", port)
    return Address(port, interface, int(index))


def _addresses(p: Prop | None, default_port: int) -> tuple[Address, ...]:
    if p is None:
        return ()
    out = []
    for v in p.values:
        if not isinstance(v, str):
            raise StageError(p.where, f'quoted addresses in {p.key} [ "port:interface:index" ]',
                             v)
        out.append(parse_address(v, default_port, p.where))
    return tuple(out)


def _string(p: Prop | None) -> str | None:
    if p is None:
        return None
    if len(p.values) != 1 or not isinstance(p.values[0], str):
        raise StageError(p.where, f"a quoted string for {p.key}", p.values)
    return p.values[0]


def _driver(e: Entity, file: Path, default_port: int, warnings: Warnings) -> DriverBlock:
    props = {p.key: p for p in e.props}
    name = _string(props.get("name"))
    if name is None:
        raise StageError(e.where, 'a name "..." in the driver block', "none")
    worldfile = _string(props.get("worldfile"))
    if name == "stage":
        for key, p in props.items():
            if key not in STAGE_KEYS:
                warnings.once(f"cfgkey:{p.where}:{key}",
                              f"{p.where}: key {key!r} of the stage driver is not used here; "
                              "ignored")
    return DriverBlock(
        name=name,
        provides=_addresses(props.get("provides"), default_port),
        requires=_addresses(props.get("requires"), default_port),
        model=_string(props.get("model")),
        worldfile=(file.parent / worldfile) if worldfile else None,
        plugin=_string(props.get("plugin")) or "",
        where=e.where,
    )


def load_player_cfg(path: Path | str, default_port: int = 6665,
                    warnings: Warnings | None = None) -> PlayerConfig:
    file = Path(path)
    warnings = warnings or Warnings()
    doc = parse_file(file)
    for p in doc.props:
        warnings.once(f"cfgtop:{p.where}", f"{p.where}: top-level key {p.key!r} is not used "
                                           "here; ignored")
    drivers = []
    for e in doc.entities:
        if e.kind != "driver":
            warnings.once(f"cfgent:{e.where}", f"{e.where}: {e.kind!r} is not a driver block; "
                                               "ignored")
            continue
        drivers.append(_driver(e, file, default_port, warnings))
    return PlayerConfig(file, tuple(drivers), tuple(warnings.said))
