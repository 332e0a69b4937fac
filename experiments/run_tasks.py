"""What a run makes of an experiment's declarations: the announcement of each of its tasks
(its kind's resources and duration), where each takes place (its kind's `place` on the
simulation's ground truth) and the allocators it may run with (`Supports`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import click

from experiments.plugin import Experiment

if TYPE_CHECKING:
    from player_server.sim import Simulation
    from worlds import WorldSpec


def supported_allocators(experiment: Experiment) -> list[str]:
    """The registered allocators `experiment` may run with (`Supports`)."""
    from murdoch.allocators import ALLOCATORS

    supports = experiment.supports
    return [name for name, a in ALLOCATORS.items()
            if (supports.allocators is None or name in supports.allocators)
            and (not supports.sub_tasks or a.sub_tasks)]


def check_supports(experiment: Experiment, allocator: str) -> None:
    """The allocator is one the experiment supports (`Supports`), else a one-line error
    naming --allocator."""
    supports = experiment.supports
    able = supported_allocators(experiment)
    if allocator not in able:
        why = " robots that auction sub-tasks," if supports.sub_tasks else ""
        raise click.BadParameter(f"{experiment.name} needs{why} one of {', '.join(able)}; "
                                 f"found {allocator}", param_hint="--allocator")


def task_spec(planned: Any) -> Any:
    """The announcement of one planned task of the task source: its kind's resources, its
    duration (`TaskSpec.duration_param`) and a contract timeout 600 s after it."""
    from behaviors.task_kinds import task_kinds
    from murdoch.auction.timing import USER_TASK

    kind = task_kinds()[planned.kind]
    duration_s = kind.duration_s(planned.params)
    return USER_TASK.task(planned.kind, kind.subjects, planned.params,
                          duration_s=duration_s, timeout_s=duration_s + 600.0)


@dataclass(frozen=True)
class WorldSite:
    """`behaviors.task_place.TaskSite` of a running simulation: ground truth when asked."""

    spec: WorldSpec
    sim: Simulation

    @property
    def camera_xy(self) -> tuple[float, float] | None:
        camera = self.spec.overhead_camera
        return None if camera is None else (float(camera.x), float(camera.y))

    def colour_xy(self, colour: str) -> tuple[float, float] | None:
        spec = self.spec
        bodies = {f"#{o.colour:06x}": o.name for o in spec.objects}
        bodies.update({f"#{b.colour:06x}": b.name for b in spec.boxes
                       if f"#{b.colour:06x}" not in bodies})
        body = bodies.get(colour.lower())
        if body is None:
            return None
        x, y, _ = self.sim.get_pose(body)
        return (float(x), float(y))


def task_place(spec: WorldSpec, sim: Simulation) -> Any:
    """Where a task is to be done, for allocators that plan paths: its kind's `place` on the
    ground truth when the task is introduced (the arena's centre when it says nowhere)."""
    from behaviors.task_kinds import task_kinds

    site = WorldSite(spec, sim)

    def place(name: str, params: Any) -> tuple[float, float]:
        kind = task_kinds().get(name)
        xy = kind.place(params, site) if kind is not None else None
        return (0.0, 0.0) if xy is None else (float(xy[0]), float(xy[1]))

    return place
