"""Where the long-term experiment's tasks come from: a seeded generator (pure).

Tasks of the paper's four kinds (object tracking, sentry duty, cleanup, monitoring with the
overhead camera) arrive at exponentially distributed intervals with random lengths; colours are
drawn from the world's objects (tracking, sentry) and boxes (cleanup).
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from worlds import WorldSpec

LONGTERM_KINDS: tuple[str, ...] = ("object-tracking", "sentry-duty", "cleanup", "monitor-object")


@dataclass(frozen=True, slots=True)
class PlannedTask:
    t_s: float
    kind: str
    params: dict[str, Any] = field(default_factory=dict)


def _colour_name(colour: int) -> str:
    return f"#{colour:06x}"


PAPER_INTERVAL_S = 240.0
"""The long-term domain's mean interval between new tasks, for its team of six robots."""
PAPER_TEAM = 6


def team_task_interval_s(world: WorldSpec) -> float:
    """The default mean interval between new tasks for `world`: the domain's 240 s for six
    mobile robots or fewer, shorter in proportion for a bigger team (a hundred robots: 14.4
    s), so that each robot is offered about as much work as in the paper's team."""
    mobile = sum(1 for r in world.robots if r.mobile)
    return PAPER_INTERVAL_S * PAPER_TEAM / max(PAPER_TEAM, mobile)


def longterm_tasks(
    world: WorldSpec,
    rng: random.Random,
    *,
    mean_interval_s: float = 240.0,
    min_length_s: float = 60.0,
    max_length_s: float = 240.0,
    start_s: float = 5.0,
    kinds: tuple[str, ...] = LONGTERM_KINDS,
) -> Iterator[PlannedTask]:
    """An endless, seeded stream of tasks in time order."""
    if mean_interval_s <= 0 or not 0 < min_length_s <= max_length_s:
        raise ValueError("need mean_interval_s > 0 and 0 < min_length_s <= max_length_s")
    object_colours = sorted({o.colour for o in world.objects}) or [0xFF0000]
    box_colours = sorted({b.colour for b in world.boxes}) or [0xFFFF00]
    usable = [k for k in kinds if k != "monitor-object" or world.overhead_camera is not None]
    t = start_s
    while True:
        kind = rng.choice(usable)
        length = round(rng.uniform(min_length_s, max_length_s), 1)
        params: dict[str, Any] = {"duration_s": length}
        if kind in ("object-tracking", "sentry-duty"):
            params["colour"] = _colour_name(rng.choice(object_colours))
        elif kind == "cleanup":
            params["colour"] = _colour_name(rng.choice(box_colours))
        yield PlannedTask(round(t, 3), kind, params)
        t += rng.expovariate(1.0 / mean_interval_s)


def boxpush_task(world: WorldSpec, duration_s: float, start_s: float = 1.0) -> PlannedTask:
    """The box-pushing domain's one user task: watch (lead) the box to the goal marker."""
    if not world.boxes or not world.markers:
        raise ValueError(f"world {world.name!r} needs a box and a goal marker for boxpush")
    box = max(world.boxes, key=lambda b: b.size_x_m * b.size_y_m)
    goal = world.markers[0]
    return PlannedTask(start_s, "watch-box", {
        "colour": _colour_name(box.colour),
        "goal_colour": _colour_name(goal.colour),
        "duration_s": max(60.0, duration_s - start_s - 5.0),
    })
