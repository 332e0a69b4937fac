"""The Stage model tree: entities resolved through their `define` chains.

A `StageModel` holds the properties of its whole definition chain (later ones override
earlier ones), its children (those of every definition, then its own), its built-in kind
(`position`, `ranger`, ...) and its name (Stage's `kind:N` when the file gives none).
`Reader` reads typed values in the file's units and warns once about keys nothing reads.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from worlds.stage.syntax import Document, Entity, Prop, StageError, Where

log = logging.getLogger(__name__)

#: built-in Stage kinds the converter knows (models, and the parts they hold)
MODEL_KINDS = frozenset({"model", "position", "ranger", "laser", "blobfinder", "fiducial",
                         "camera", "gripper", "bumper", "actuator", "blinkenlight",
                         "lightindicator"})
PART_KINDS = frozenset({"sensor", "block"})
GUI_ENTITIES = frozenset({"window", "gui", "canvas"})


@dataclass(frozen=True)
class StageModel:
    kind: str  # the built-in kind at the root of the definition chain
    token: str  # the kind as written (e.g. "pioneer2dx")
    name: str
    props: Mapping[str, Prop]
    children: tuple[StageModel, ...]
    parts: tuple[StageModel, ...]  # sensors and blocks
    where: Where

    def descendants(self) -> list[StageModel]:
        out: list[StageModel] = []
        for c in self.children:
            out.append(c)
            out.extend(c.descendants())
        return out


@dataclass
class Warnings:
    """Warns once per (what, where) and remembers what it said (for tests and reports)."""

    said: list[str] = field(default_factory=list)
    _keys: set[str] = field(default_factory=set)

    def once(self, key: str, message: str) -> None:
        if key in self._keys:
            return
        self._keys.add(key)
        self.said.append(message)
        log.warning("%s", message)


def _chain(kind: str, defines: Mapping[str, object], where: Where) -> list[str]:
    """The definition chain of a kind, from the built-in root to the kind itself."""
    chain = [kind]
    while chain[-1] not in MODEL_KINDS and chain[-1] not in PART_KINDS:
        d = defines.get(chain[-1])
        if d is None:
            return chain[::-1]  # ends in an unknown kind: the caller warns
        base = d.base  # type: ignore[attr-defined]
        if base in chain:
            raise StageError(where, f"a definition chain without a loop (kind {kind})", base)
        chain.append(base)
    return chain[::-1]


class TreeBuilder:
    def __init__(self, doc: Document, warnings: Warnings) -> None:
        self.doc = doc
        self.warnings = warnings
        self.counts: dict[str, int] = {}

    def build(self) -> list[StageModel]:
        out: list[StageModel] = []
        for e in self.doc.entities:
            if e.kind in GUI_ENTITIES:
                continue
            m = self.model(e, "")
            if m is not None:
                out.append(m)
        return out

    def model(self, e: Entity, parent: str) -> StageModel | None:
        chain = _chain(e.kind, self.doc.defines, e.where)
        if chain[0] not in MODEL_KINDS and chain[0] not in PART_KINDS:
            via = f" (defined from {chain[0]!r}, which is not one)" if len(chain) > 1 else ""
            self.warnings.once(f"kind:{chain[0]}", f"{e.where}: unknown model kind "
                                                   f"{e.kind!r}{via}; ignored")
            return None
        bodies = [self.doc.defines[k].body for k in chain[1:]] + [e]
        props: dict[str, Prop] = {}
        raw_children: list[Entity] = []
        for b in bodies:
            for p in b.props:
                props[p.key] = p
            raw_children.extend(b.children)
        root = chain[0]
        n = self.counts.get(root if not parent else f"{parent}/{root}", 0)
        self.counts[root if not parent else f"{parent}/{root}"] = n + 1
        name_prop = props.get("name")
        if name_prop is not None and isinstance(name_prop.values[0], str):
            name = name_prop.values[0]
        else:
            name = f"{parent}.{root}:{n}" if parent else f"{e.kind}:{n}"
        children: list[StageModel] = []
        parts: list[StageModel] = []
        for c in raw_children:
            if c.kind in GUI_ENTITIES:
                continue
            m = self.model(c, name)
            if m is None:
                continue
            (parts if m.kind in PART_KINDS else children).append(m)
        return StageModel(root, e.kind, name, props, tuple(children), tuple(parts), e.where)


class Reader:
    """Typed values of one model (or of the globals) in metres and radians.

    Every key read is marked; `finish` warns once about the keys of this model nothing
    read (with the line where the key was written)."""

    def __init__(self, owner: str, props: Mapping[str, Prop], units: Units,
                 warnings: Warnings, ignored: frozenset[str] = frozenset()) -> None:
        self.owner = owner
        self.props = props
        self.units = units
        self.warnings = warnings
        self.used: set[str] = set(ignored)

    def has(self, key: str) -> bool:
        self.used.add(key)
        return key in self.props

    def where(self, key: str, default: Where) -> Where:
        p = self.props.get(key)
        return p.where if p is not None else default

    def _values(self, key: str) -> tuple[object, ...] | None:
        self.used.add(key)
        p = self.props.get(key)
        if p is None:
            return None
        if any(isinstance(v, float) and not math.isfinite(v) for v in p.values):
            raise StageError(p.where, f"finite numbers for {key}", _show(p.values))
        return p.values

    def number(self, key: str, default: float) -> float:
        v = self._values(key)
        if v is None:
            return default
        if len(v) != 1 or not isinstance(v[0], float):
            raise StageError(self.props[key].where, f"one number for {key}", _show(v))
        return v[0]

    def string(self, key: str, default: str) -> str:
        v = self._values(key)
        if v is None:
            return default
        if len(v) != 1 or not isinstance(v[0], str):
            raise StageError(self.props[key].where, f"a quoted string for {key}", _show(v))
        return v[0]

    def numbers(self, key: str, n: int, default: tuple[float, ...],
                min_n: int | None = None) -> tuple[float, ...]:
        """n numbers (fewer, down to min_n, are padded from the default)."""
        v = self._values(key)
        if v is None:
            return default
        lo = n if min_n is None else min_n
        if not lo <= len(v) <= n or not all(isinstance(x, float) for x in v):
            count = f"{n}" if lo == n else f"{lo} to {n}"
            raise StageError(self.props[key].where, f"[ {count} numbers ] for {key}", _show(v))
        got = tuple(float(x) for x in v)  # type: ignore[arg-type]
        return got + default[len(got):]

    def length(self, key: str, default: float) -> float:
        return self.number(key, default / self.units.length) * self.units.length

    def angle(self, key: str, default_rad: float) -> float:
        return self.number(key, default_rad / self.units.angle) * self.units.angle

    def pose(self, key: str = "pose") -> tuple[float, float, float, float]:
        """x, y, z in metres, yaw in radians (Stage 4 [x y z a]; older [x y a])."""
        v = self._values(key)
        if v is None:
            return (0.0, 0.0, 0.0, 0.0)
        if len(v) == 3:
            x, y, a = self.numbers(key, 3, (0.0, 0.0, 0.0))
            z = 0.0
        else:
            x, y, z, a = self.numbers(key, 4, (0.0, 0.0, 0.0, 0.0))
        u = self.units.length
        return (x * u, y * u, z * u, a * self.units.angle)

    def size(self, default: tuple[float, float, float]) -> tuple[float, float, float]:
        u = self.units.length
        v = self.numbers("size", 3, tuple(d / u for d in default), min_n=2)
        return (v[0] * u, v[1] * u, v[2] * u)

    def finish(self, default_where: Where) -> None:
        for key, p in self.props.items():
            if key not in self.used and key != "name":
                self.warnings.once(f"key:{p.where}:{key}",
                                   f"{p.where}: key {key!r} of {self.owner} is not used here; "
                                   "ignored")


@dataclass(frozen=True)
class Units:
    length: float = 1.0  # metres per file unit
    angle: float = math.pi / 180.0  # radians per file unit


def units_of(props: Mapping[str, Prop]) -> Units:
    def pick(key: str, table: dict[str, float], default: float) -> float:
        p = props.get(key)
        if p is None:
            return default
        v = p.values[0] if len(p.values) == 1 else None
        if not isinstance(v, str) or v not in table:
            raise StageError(p.where, f"one of {', '.join(table)} for {key}", _show(p.values))
        return table[v]

    return Units(pick("unit_length", {"m": 1.0, "cm": 0.01, "mm": 0.001}, 1.0),
                 pick("unit_angle", {"degrees": math.pi / 180.0, "radians": 1.0},
                      math.pi / 180.0))


def _show(v: object) -> str:
    if isinstance(v, tuple):
        if len(v) == 1:
            return repr(v[0])
        return "[" + " ".join(repr(x) if isinstance(x, str) else f"{x:g}" for x in v) + "]"
    return repr(v)


ModelFilter = Callable[[StageModel], bool]
