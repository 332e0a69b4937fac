"""What the experiment checkers share: the experiment by name, its world and options, the
first tasks of its stream, and how a broken rule is said (one line, `ContractError`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from experiments.plugin import Experiment, PlannedTask, RunOptions
from murdoch.plugin import ContractError, PluginError

if TYPE_CHECKING:
    from worlds import WorldSpec

MAX_TASKS = 40
"""How many tasks of the stream a check draws."""


def rule(ok: bool, name: str, rule: str) -> None:
    """`ContractError` naming the experiment and the `rule` unless `ok`."""
    if not ok:
        raise ContractError(f"experiment {name!r}: {rule}")


def resolve(experiment: Experiment | str) -> Experiment:
    """The experiment itself, or the registered one of that name (`PluginError` if none)."""
    from experiments.registry import experiments

    if not isinstance(experiment, str):
        return experiment
    found = experiments().get(experiment)
    if found is None:
        raise PluginError(f"no experiment {experiment!r}; known: {', '.join(experiments())}")
    return found


def world_of(plugin: Experiment) -> WorldSpec:
    """The world the experiment runs in by default (a name, or a .toml path)."""
    from worlds import load_world, world_path

    if plugin.world.endswith(".toml"):
        return load_world(Path(plugin.world))
    return load_world(world_path(plugin.world))


def checked_options(plugin: Experiment, spec: WorldSpec, duration_s: float,
                    seed: int) -> RunOptions:
    """Its options at their defaults, as its `check` makes them against the world."""
    options = plugin.check(spec, RunOptions.of(plugin, duration_s, seed))
    rule(isinstance(options, RunOptions), plugin.name, "check() must return the RunOptions")
    return options


def draw(plugin: Experiment, spec: WorldSpec, options: RunOptions) -> list[PlannedTask]:
    """The first tasks of its stream within the run (at most `MAX_TASKS`)."""
    out: list[PlannedTask] = []
    for task in plugin.tasks(spec, options):
        if task is None or task.t_s >= options.duration_s or len(out) >= MAX_TASKS:
            break
        out.append(task)
    return out


def is_json(value: object) -> bool:
    """Whether `value` is made of JSON values only (no NaN or infinity)."""
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        return False
    return True


def is_json_object(value: object) -> bool:
    return isinstance(value, dict) and is_json(value)


def mobile_robots(spec: Any) -> tuple[str, ...]:
    """The world's mobile robots in its order (its robots if none is mobile)."""
    mobile = tuple(r.name for r in spec.robots if r.mobile)
    return mobile or tuple(r.name for r in spec.robots)
