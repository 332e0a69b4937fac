"""Fast positional constructors of frozen dataclasses: the one place they are generated.

The generated ``__init__`` of a frozen dataclass calls ``object.__setattr__`` once per field.
Values built by the thousand every simulated second (decoded Player bodies, simulator
readings, robot snapshots) are made another way, giving an object equal to, and as frozen
as, ``cls(*args)``:

- a slotted class: an instance of a plain twin class with the same slots is filled by
  ordinary assignments and then becomes a ``cls`` (``__class__`` is assigned; the layouts are
  identical); when the layouts are not compatible (a base with slots), each slot is set
  through its descriptor;
- a class with an instance dict: the dict is filled in one update.

Defaults are not applied and ``__post_init__`` is not run: every field is passed, in
declaration order. Shared by `player_server.protocol`, `player_server.sim` and `behaviors`
(it imports nothing from any of them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")


def _compile(lines: list[str], ns: dict[str, Any]) -> Callable[..., Any]:
    exec("\n".join(lines), ns)
    make: Callable[..., Any] = ns["make"]
    return make


def frozen_constructor(cls: type[T]) -> Callable[..., T]:
    """A positional constructor of the frozen dataclass `cls` (see the module's notes)."""
    names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
    args = ", ".join(f"a{i}" for i in range(len(names)))
    head = f"def make({args}):"
    if "__slots__" not in cls.__dict__:
        items = ", ".join(f"{n!r}: a{i}" for i, n in enumerate(names))
        return _compile([head, "    o = _new(_cls)", f"    o.__dict__.update({{{items}}})",
                         "    return o"], {"_new": object.__new__, "_cls": cls})
    twin = type(f"_{cls.__name__}Slots", (), {"__slots__": tuple(names)})
    lines = [head, "    o = _new(_twin)"]
    lines += [f"    o.{name} = a{i}" for i, name in enumerate(names)]
    lines += ["    o.__class__ = _cls", "    return o"]
    make = _compile(lines, {"_new": object.__new__, "_cls": cls, "_twin": twin})
    try:
        make(*range(len(names)))
    except TypeError:  # not layout-compatible (e.g. a base with slots): set each slot
        ns: dict[str, Any] = {"_new": object.__new__, "_cls": cls}
        lines = [head, "    o = _new(_cls)"]
        for i, name in enumerate(names):
            ns[f"_s{i}"] = _slot(cls, name).__set__
            lines.append(f"    _s{i}(o, a{i})")
        lines.append("    return o")
        make = _compile(lines, ns)
    return make


def _slot(cls: type, name: str) -> Any:
    for klass in cls.__mro__:
        if name in klass.__dict__:
            return klass.__dict__[name]
    raise TypeError(f"{cls.__name__} has no slot {name!r}")
