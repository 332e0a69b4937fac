"""Where a task takes place, for allocators that plan by distance (pure).

A task kind may say where one of its tasks is done (`TaskSpec.place`): a function of the
task's parameters and a `TaskSite`, what the runner knows of the world when the task is
introduced. Kinds that say nothing use `default_place`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

XY = tuple[float, float]


class TaskSite(Protocol):
    """What a place function may ask of the world when a task is introduced."""

    @property
    def camera_xy(self) -> XY | None:
        """Where the overhead camera's desk is (None: the world has none)."""
        ...

    def colour_xy(self, colour: str) -> XY | None:
        """Where the object (else the box) of colour ``#rrggbb`` is now (None: no such)."""
        ...


Place = Callable[[Mapping[str, object], TaskSite], XY | None]
"""(task parameters, site) -> (x, y) in metres, or None: nowhere in particular."""


def default_place(params: Mapping[str, object], site: TaskSite) -> XY | None:
    """The task's own ``x`` and ``y`` parameters; else where the object or box of its
    ``colour`` is; else nowhere in particular."""
    if "x" in params and "y" in params:
        return (float(str(params["x"])), float(str(params["y"])))
    return site.colour_xy(str(params.get("colour", "")).lower())


def camera_place(params: Mapping[str, object], site: TaskSite) -> XY | None:
    """At the overhead camera's desk (a task for the camera), else as `default_place`."""
    camera = site.camera_xy
    return camera if camera is not None else default_place(params, site)
