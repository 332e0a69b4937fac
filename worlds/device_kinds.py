"""Device kinds of the world file: each declares its own parameters, and the loader reads them.

A kind is a frozen dataclass of parameters, each field declared with `param` (its default, a
one-line doc, its world-file key and bounds), decorated with `declare_device`, which names the
robot sub-table (``[robots.<name>]``) and registers it. The loader reads every declared kind's
table with `read_params` (the same one-line `WorldError`s as every other key: file, key,
expected, found; unknown keys are errors) and `worlds.to_toml` writes it back with
`param_items`. A kind whose table needs more than scalar keys (the sonar's poses, the
bumper's segments) gives its own ``read`` and ``write``.

The built-in kinds are declared in `worlds.builtin_devices` (their specs, the typed slots of
`DeviceSet`, stay in `worlds.spec`); any other kind is one module in the package
`worlds.devices`, found there by `device_kinds` without being listed anywhere. Everything here
is pure description: a robot process reads the same world files without the simulator.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from worlds.params import Param, declared_params, param, param_docs, param_items

if TYPE_CHECKING:
    from worlds.reader import Table
    from worlds.spec import BodySpec

__all__ = [
    "DeviceKind", "Param", "RobotContext", "declare_device", "declared_params", "device_kinds",
    "param", "param_docs", "param_items", "read_params",
]


def read_params(cls: type, t: Table, **given: Any) -> Any:
    """An instance of `cls` with its parameters read from `t` (defaults where absent); the
    fields that are not parameters, and defaults that depend on the robot, come in `given`."""
    values = dict(given)
    for name, key, p in declared_params(cls):
        default = values.get(name, getattr(cls, name, None))
        if p.kind == "number":
            values[name] = t.number(key, default, min_value=p.min, max_value=p.max,
                                    positive=p.positive)
        elif p.kind == "integer":
            low = None if p.min is None else int(p.min)
            high = None if p.max is None else int(p.max)
            values[name] = t.integer(key, default, min_value=low, max_value=high)
        elif p.kind == "angle":
            values[name] = t.angle(key, default, min_rad=p.min, max_rad=p.max)
        elif p.kind == "mount":
            if default is None:
                raise TypeError(f"{cls.__qualname__}.{name}: a mount needs a default (given)")
            values[name] = t.mount(key, default)
        elif p.kind == "colour":
            values[name] = t.colour(key, default)
        elif p.kind == "boolean":
            values[name] = t.boolean(key, bool(default))
        else:
            values[name] = t.string(key, default)
    return cls(**values)


@dataclass(frozen=True)
class RobotContext:
    """What a device's reader may know of its robot besides its own table."""

    body: BodySpec
    present: tuple[str, ...]
    """The robot's other devices read so far (every other one, for a ``late`` kind)."""


@dataclass(frozen=True)
class DeviceKind:
    """One kind of device a robot may declare in the world file."""

    name: str
    """Its robot sub-table, ``[robots.<name>]``, and its name everywhere (models, drivers)."""
    params: type
    doc: str
    draw_w: float = 0.0
    """What it adds to a robot's default `power.sensor_draw` (W)."""
    needs: tuple[str, ...] = ()
    """Devices the same robot must declare with it."""
    late: bool = False
    """Read after every other device of the robot (its defaults depend on them)."""
    read: Callable[[Table, RobotContext], Any] | None = None
    """Its own reader; by default `read_params` of `params`."""
    write: Callable[[Any], list[tuple[str, Any]]] | None = None
    """Its own writer; by default `param_items`."""

    def read_table(self, t: Table, ctx: RobotContext) -> Any:
        if self.read is not None:
            return self.read(t, ctx)
        return read_params(self.params, t)

    def items(self, spec: Any) -> list[tuple[str, Any]]:
        return self.write(spec) if self.write is not None else param_items(spec)


_KINDS: dict[str, DeviceKind] = {}


def declare_device(name: str, *, doc: str, draw_w: float = 0.0, needs: tuple[str, ...] = (),
                   late: bool = False, read: Callable[[Table, RobotContext], Any] | None = None,
                   write: Callable[[Any], list[tuple[str, Any]]] | None = None
                   ) -> Callable[[type], type]:
    """Class decorator: the frozen dataclass is the parameters of the device kind `name`."""

    def register(cls: type) -> type:
        if name in _KINDS and _KINDS[name].params is not cls:
            raise ValueError(f"device kind {name!r} is declared twice "
                             f"({_KINDS[name].params.__qualname__}, {cls.__qualname__})")
        _KINDS[name] = DeviceKind(name, cls, doc, draw_w, needs, late, read, write)
        return cls

    return register


_ordered: dict[str, DeviceKind] = {}


def device_kinds() -> dict[str, DeviceKind]:
    """Every declared kind by name: the built-ins in `DeviceSet` order, then the kinds of
    `worlds.devices` by name (whichever module was imported first)."""
    if not _ordered:
        importlib.import_module("worlds.builtin_devices")
        package = importlib.import_module("worlds.devices")
        for mod in sorted(m.name for m in pkgutil.iter_modules(package.__path__)):
            importlib.import_module(f"worlds.devices.{mod}")
        built_in = [k for k in _KINDS.values() if k.params.__module__ == "worlds.spec"]
        others = sorted((k for k in _KINDS.values() if k not in built_in), key=lambda k: k.name)
        _ordered.update((k.name, k) for k in built_in + others)
    return _ordered
