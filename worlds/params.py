"""A world-file parameter, declared on the field of a frozen spec dataclass.

``max_range_m: float = param(5.0, "the longest range reported (m)", positive=True)`` makes
the field a parameter: the loader reads it from the key ``max_range`` with those bounds
(`worlds.device_kinds.read_params`), `worlds.to_toml` writes it back (`param_items`) and the
docs list it (`param_docs`). Nothing here imports the rest of `worlds`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

__all__ = [
    "REQUIRED", "Param", "ParamKind", "declared_params", "param", "param_docs", "param_items",
]

REQUIRED: Any = dataclasses.MISSING
"""The default of a parameter the spec cannot do without (its reader gives one)."""

ParamKind = Literal["number", "integer", "angle", "mount", "colour", "boolean", "string"]


@dataclass(frozen=True)
class Param:
    """How one parameter appears in the world file."""

    key: str
    """The world-file key (an angle is ``<key>_deg`` or ``<key>_rad``)."""
    doc: str
    kind: ParamKind = "number"
    min: float | None = None
    """Inclusive lower bound (radians for an angle)."""
    max: float | None = None
    """Inclusive upper bound (radians for an angle)."""
    positive: bool = False
    """A number that must be > 0."""


def param(default: Any, doc: str, *, key: str = "", kind: ParamKind | None = None,
          min: float | None = None, max: float | None = None,
          positive: bool = False) -> Any:
    """A dataclass field that is a world-file parameter (``key`` defaults to the field's name
    less a unit suffix: ``max_range_m`` is ``max_range``; ``kind`` to the default's type: a
    boolean, integer, string or number; an angle, mount or colour says so)."""
    if kind is None:
        kind = ("boolean" if isinstance(default, bool) else "integer" if isinstance(default, int)
                else "string" if isinstance(default, str) else "number")
    return dataclasses.field(default=default, metadata={
        "param": Param(key, doc, kind, min, max, positive)})


_UNITS = ("_radps2", "_radps", "_rad", "_mps2", "_mps", "_m", "_s", "_px", "_w", "_j")


def _key(f: dataclasses.Field[Any], p: Param) -> str:
    if p.key:
        return p.key
    for unit in _UNITS:
        if f.name.endswith(unit):
            return f.name.removesuffix(unit)
    return f.name


def declared_params(cls: type) -> list[tuple[str, str, Param]]:
    """The parameters `cls` declares with `param`: (field name, world-file key, Param)."""
    out = []
    for f in dataclasses.fields(cls):
        p = f.metadata.get("param")
        if p is not None:
            out.append((f.name, _key(f, p), p))
    return out


def param_items(spec: Any) -> list[tuple[str, Any]]:
    """The declared parameters of `spec` as world-file (key, value) pairs, angles in radians
    (``<key>_rad``), so that `read_params` reads back the same spec."""
    out: list[tuple[str, Any]] = []
    for name, key, p in declared_params(type(spec)):
        out.append((f"{key}_rad" if p.kind == "angle" else key, getattr(spec, name)))
    return out


def param_docs(cls: type) -> list[str]:
    """One line per parameter: ``key`` (default): doc."""
    lines = []
    for name, key, p in declared_params(cls):
        default = getattr(cls, name, None)
        if p.kind == "angle" and isinstance(default, float):
            key, default = f"{key}_deg", round(math.degrees(default), 6)
        lines.append(f"`{key}` ({default}): {p.doc}")
    return lines
