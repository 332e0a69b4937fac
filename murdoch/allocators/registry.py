"""The allocators by name: the built-ins and those installed packages register.

A package registers allocators under the entry-point group `murdoch.allocators`, each as
`name = "pkg.module:Attribute"`, the attribute a `murdoch.plugin.CentralAllocator` subclass
(wrapped by `murdoch.plugin.central_allocator`) or a `murdoch.allocators.base.Allocator`.
The built-ins are loaded the same way from `BUILTINS`. Loading happens once, on first use;
a plugin that fails to import, is neither, takes a name already taken or whose name differs
from its class's is left out and named in one line (`problems`), and `check` raises the
first as `PluginError`, so that no run starts with a broken plugin around.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Iterator, Mapping
from importlib.metadata import entry_points

from murdoch.allocators.base import Allocator
from murdoch.execution.central import CentralAllocator, central_allocator


class PluginError(Exception):
    """An allocator plugin that cannot be used; its message is one line naming it."""

GROUP = "murdoch.allocators"
BUILTINS: tuple[tuple[str, str], ...] = (
    ("murdoch", "murdoch.allocators.murdoch_auctions:MURDOCH"),
    ("cbba", "murdoch.allocators.cbba:CBBA"),
    ("cbga", "murdoch.allocators.cbga:CBGA"),
    ("greedy", "murdoch.allocators.greedy:Greedy"),
    ("optimal", "murdoch.allocators.optimal:Optimal"),
)
NAME = re.compile(r"[a-z][a-z0-9_-]*\Z")


def load(name: str, value: str) -> Allocator:
    """The allocator `value` ("module:attribute") names; ValueError saying what is wrong."""
    module_name, _, attr = value.partition(":")
    try:
        found = getattr(importlib.import_module(module_name), attr)
    except Exception as exc:  # a plugin's import may raise anything
        raise ValueError(f"cannot load {value}: {type(exc).__name__}: {exc}") from None
    if isinstance(found, type) and issubclass(found, CentralAllocator):
        if found.name != name:
            raise ValueError(f"{value} is called {found.name!r}, not {name!r}")
        if found.choose is CentralAllocator.choose and found.assign is CentralAllocator.assign:
            raise ValueError(f"{value} breaks the contract: it overrides neither choose "
                             f"nor assign")
        return central_allocator(found)
    if isinstance(found, Allocator):
        if found.name != name:
            raise ValueError(f"{value} is called {found.name!r}, not {name!r}")
        return found
    raise ValueError(f"{value} is {type(found).__name__}, expected a CentralAllocator "
                     f"subclass or an Allocator")


class Registry(Mapping[str, Allocator]):
    """Name -> allocator, in registration order (the built-ins first)."""

    def __init__(self, builtins: tuple[tuple[str, str], ...] = BUILTINS,
                 group: str | None = GROUP) -> None:
        self._builtins = builtins
        self._group = group
        self._found: dict[str, Allocator] | None = None
        self._problems: list[str] = []

    @property
    def problems(self) -> tuple[str, ...]:
        """One line for each plugin left out."""
        self._loaded()
        return tuple(self._problems)

    def check(self) -> None:
        """Raise `PluginError` with the first problem, if any."""
        if self.problems:
            raise PluginError(self.problems[0])

    def _loaded(self) -> dict[str, Allocator]:
        if self._found is None:
            found: dict[str, Allocator] = {}
            sources = [(n, v, "built in") for n, v in self._builtins]
            if self._group is not None:
                sources += [(e.name, e.value, f"from {e.dist.name if e.dist else 'a package'}")
                            for e in entry_points(group=self._group)]
            for name, value, origin in sources:
                where = f"allocator plugin {name!r} ({value}, {origin})"
                if not NAME.match(name):
                    self._problems.append(f"{where}: the name must be lowercase letters, "
                                          f"digits, '-' or '_'")
                elif name in found:
                    self._problems.append(f"{where}: the name {name!r} is already taken")
                else:
                    try:
                        found[name] = load(name, value)
                    except ValueError as exc:
                        self._problems.append(f"{where}: {exc}")
            self._found = found
        return self._found

    def __getitem__(self, name: str) -> Allocator:
        return self._loaded()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._loaded())

    def __len__(self) -> int:
        return len(self._loaded())
