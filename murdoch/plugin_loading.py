"""Plugins from other installed packages: entry points loaded by group, with one-line errors.

A package adds allocators, task kinds or experiments by naming objects in its
``[project.entry-points."murdoch.GROUP"]`` table. `load_group` imports each one and hands it
to a check of the group's contract; anything wrong (the import fails, the object breaks the
contract, the name is taken) is a `PluginError` whose message is one line naming the plugin,
its package and what was expected, so that a command can print it and not start.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from importlib.metadata import EntryPoint, entry_points
from typing import TypeVar

from murdoch.plugin import PluginError

T = TypeVar("T")

__all__ = ["PluginError", "describe", "load_group"]


def describe(ep: EntryPoint) -> str:
    """'murdoch.tasks patrol-waypoints = murdoch_patrol.kinds:PATROL (murdoch-patrol 0.1)'."""
    dist = getattr(ep, "dist", None)
    where = f" ({dist.name} {dist.version})" if dist is not None else ""
    return f"{ep.group} plugin {ep.name!r} = {ep.value}{where}"


def load_group(group: str, accept: Callable[[object, str], Iterable[T]],
               taken: Mapping[str, object]) -> dict[str, T]:
    """Every object the entry points of `group` name, by name.

    `accept(obj, where)` turns a loaded object into the plugins it holds (an object may be
    one plugin or a collection of them) or raises `PluginError`; a name already in `taken`
    (the built-in ones) or given twice is refused."""
    found: dict[str, T] = {}
    origin: dict[str, str] = {}
    for ep in sorted(entry_points(group=group), key=lambda e: (e.name, e.value)):
        where = describe(ep)
        try:
            obj = ep.load()
        except Exception as exc:  # whatever the plugin raised, in one line
            raise PluginError(f"{where}: cannot be imported: {type(exc).__name__}: "
                              f"{_one_line(exc)}") from None
        for name, plugin in _named(accept(obj, where), where):
            if name in taken:
                raise PluginError(f"{where}: the name {name!r} is taken by a built-in one")
            if name in found:
                raise PluginError(f"{where}: the name {name!r} is taken by {origin[name]}")
            found[name] = plugin
            origin[name] = where
    return found


def _named(plugins: Iterable[T], where: str) -> Iterable[tuple[str, T]]:
    for plugin in plugins:
        name = getattr(plugin, "name", None)
        if not isinstance(name, str) or not name:
            raise PluginError(f"{where}: expected a plugin with a non-empty str `name`, "
                              f"found {type(plugin).__name__}")
        yield name, plugin


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:300] + ("..." if len(text) > 300 else "")
