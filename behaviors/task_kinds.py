"""The task kinds a robot can execute: the library's own and those of installed packages.

Packages add task kinds through the ``murdoch.tasks`` entry point group: each entry names a
`behaviors.library.TaskSpec` (or a sequence of them). Robots (`murdoch-robot`) and the
runner load the same registry, so a task kind an experiment introduces is one every robot
knows. `check_task_kind` states the contract a kind must honour; a plugin that breaks it,
fails to import or takes a name already used is a `PluginError` of one line.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping

from behaviors.library import INTERNAL_TASKS, TASKS, TaskSpec
from behaviors.params import ParamError
from murdoch.plugin_loading import PluginError, load_group

GROUP = "murdoch.tasks"


def check_task_kind(kind: object, where: str = "task kind") -> TaskSpec:
    """`kind` if it is a usable task kind, else a `PluginError` naming the broken rule."""
    if not isinstance(kind, TaskSpec):
        raise PluginError(f"{where}: expected a TaskSpec (murdoch_api.TaskKind), found "
                          f"{type(kind).__name__}")
    name = kind.name
    if not name or any(c.isspace() for c in name):
        raise PluginError(f"{where}: expected a task kind name without spaces, found {name!r}")
    if not isinstance(kind.subjects, frozenset) or not all(
            isinstance(s, str) for s in kind.subjects):
        raise PluginError(f"{where}: task kind {name!r}: subjects must be a frozenset of str")
    if not callable(kind.build_plan) or not callable(kind.place):
        raise PluginError(f"{where}: task kind {name!r}: build_plan and place must be "
                          "callable")
    if kind.duration_param is not None and kind.duration_param not in kind.defaults \
            and kind.duration_param not in kind.required:
        raise PluginError(f"{where}: task kind {name!r}: its duration parameter "
                          f"{kind.duration_param!r} has no default and is not required")
    if kind.duration_param is not None and kind.duration_param in kind.defaults:
        try:
            kind.duration_s({k: kind.defaults.get(k, 0.0) for k in kind.required})
        except ParamError as exc:
            raise PluginError(f"{where}: task kind {name!r}: default duration: {exc}") from None
    return kind


def _accept(obj: object, where: str) -> Iterable[TaskSpec]:
    kinds = obj if isinstance(obj, (list, tuple)) else (obj,)
    return [check_task_kind(k, where) for k in kinds]


@functools.cache
def _installed() -> dict[str, TaskSpec]:
    return load_group(GROUP, _accept, {**TASKS, **INTERNAL_TASKS})


def task_kinds() -> Mapping[str, TaskSpec]:
    """Every task kind that may be introduced: the library's, then the installed packages'
    (`PluginError` if one of those is broken)."""
    return {**TASKS, **_installed()}


def task_kind(name: str) -> TaskSpec:
    """The kind `name`, the robot's internal ones (dock, undock) included; `ParamError` if
    there is none."""
    kind = task_kinds().get(name) or INTERNAL_TASKS.get(name)
    if kind is None:
        raise ParamError(f"unknown task {name!r}; known: {', '.join(sorted(task_kinds()))}")
    return kind
