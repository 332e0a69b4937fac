"""`check_experiment`: drive an experiment through a short scripted scenario and name the
first rule of the contract it breaks (`murdoch.plugin.ContractError`).

The scenario, without a simulator: the declaration is checked (`registry.check_declaration`),
the options are checked against the experiment's world, its tasks are drawn twice from the
same seed (the same stream both times: determinism), each task's kind, parameters, duration
and place are checked, its faults and config are checked, and its summary sections, plots,
verdict and next steps are asked of a scripted run's events in which tasks arrive, a robot
is killed holding one, one is unachievable and one completes, and its referee is driven
through a scripted run of its own (`experiments.referee_check`). With ``run=True`` the
experiment also runs for real for a few simulated minutes (a busy robot killed and started
again), and every task must end in exactly one terminal state.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from behaviors.params import ParamError
from behaviors.task_kinds import check_task_kind, task_kinds
from experiments import events as ev
from experiments.check_setup import (
    checked_options,
    draw,
    is_json,
    is_json_object,
    resolve,
    rule,
    world_of,
)
from experiments.plugin import Experiment, Fault, PlannedTask, RunOptions, Verdict
from experiments.referee_check import RUNNER_ACTIONS, check_referee
from murdoch.plugin import ContractError, PluginError


@dataclass(frozen=True)
class StaticSite:
    """A `TaskSite` of the world as described (objects where the world puts them)."""

    spec: Any

    @property
    def camera_xy(self) -> tuple[float, float] | None:
        camera = self.spec.overhead_camera
        return None if camera is None else (float(camera.x), float(camera.y))

    def colour_xy(self, colour: str) -> tuple[float, float] | None:
        for body in (*self.spec.objects, *self.spec.boxes):
            if f"#{body.colour:06x}" == colour.lower():
                return (float(body.pose.x), float(body.pose.y))
        return None


def check_experiment(experiment: Experiment | str, *, duration_s: float = 3600.0,
                     seed: int = 1, run: bool = False, out: Path | None = None) -> None:
    """Drive `experiment` (or the registered one of that name) through the scripted scenario;
    `ContractError` names the first rule it breaks (`PluginError` for a broken declaration)."""
    from experiments.registry import check_declaration

    plugin = check_declaration(resolve(experiment))
    name = plugin.name
    spec = world_of(plugin)
    options = checked_options(plugin, spec, duration_s, seed)
    rule(is_json_object(plugin.config(options)), name, "config() must be a JSON object")
    planned = draw(plugin, spec, options)
    rule(planned == draw(plugin, spec, options), name,
          "tasks() must give the same tasks for the same world, seed and options")
    rule(bool(planned), name, f"tasks() introduced nothing in {duration_s:g} s")
    for task in planned:
        _check_task(name, plugin, task, spec, duration_s)
    _check_faults(name, plugin, spec, options)
    _check_reports(name, plugin, planned, spec)
    check_referee(plugin, duration_s=duration_s, seed=seed)
    if run:
        _real_run(plugin, seed, out)


def _check_task(name: str, plugin: Experiment, task: PlannedTask, spec: Any,
                duration_s: float) -> None:
    rule(isinstance(task, PlannedTask), name, "tasks() must yield PlannedTask or None")
    what = f"task {task.kind!r} at {task.t_s:g} s"
    rule(task.kind in plugin.task_kinds, name, f"{what}: its kind is not in task_kinds")
    kind = task_kinds().get(task.kind)
    rule(kind is not None, name, f"{what}: its kind is not registered")
    assert kind is not None
    try:
        check_task_kind(kind, f"task kind {task.kind!r}")
    except PluginError as exc:
        raise ContractError(f"experiment {name!r}: {exc}") from None
    rule(0.0 <= task.t_s < duration_s, name, f"{what}: its time must be within the run")
    rule(is_json(dict(task.params)), name, f"{what}: its params must be JSON values")
    try:
        kind.resolve(task.params)
        length = kind.duration_s(task.params)
    except ParamError as exc:
        raise ContractError(f"experiment {name!r}: {what}: {exc}") from None
    rule(kind.duration_param is not None and length > 0, name,
          f"{what}: a user task needs a positive duration ({kind.duration_param})")
    xy = kind.place(task.params, StaticSite(spec))
    rule(xy is None or (len(xy) == 2 and all(math.isfinite(float(v)) for v in xy)), name,
          f"{what}: place() must give (x, y) or None")


def _check_faults(name: str, plugin: Experiment, spec: Any, options: RunOptions) -> None:
    own = plugin.referee(spec, options).fault_actions()
    for fault in plugin.faults(options):
        rule(isinstance(fault, Fault), name, "faults() must give Fault entries")
        rule(0.0 <= fault.t_s < options.duration_s, name,
              f"fault {fault.action} {fault.label()}: its time must be within the run")
        rule(fault.action in RUNNER_ACTIONS or fault.action in own, name,
              f"fault {fault.action}: neither the runner's nor its referee's action")


def _scripted_events(planned: list[PlannedTask], spec: Any) -> list[Mapping[str, Any]]:
    """A run's events: the first tasks arrive, one completes, a robot holding one is
    killed (the task goes back and fails), one is unachievable."""
    robot = next((r.name for r in spec.robots if r.mobile), "r1")
    out: list[Mapping[str, Any]] = [{"t": 0.0, "kind": ev.RUN_START, "experiment": "check"}]
    ends = (ev.COMPLETED, ev.FAILED, ev.UNACHIEVABLE)
    for i, task in enumerate(planned[:3]):
        tid = f"t{i}"
        out.append({"t": task.t_s, "kind": ev.TASK_INTRODUCED, "task": tid,
                    "task_kind": task.kind, "params": dict(task.params), "source": "user"})
        if ends[i] != ev.UNACHIEVABLE:
            out.append({"t": task.t_s + 1.0, "kind": ev.AWARD, "task": tid, "robot": robot})
        if ends[i] == ev.FAILED:
            out.append({"t": task.t_s + 2.0, "kind": ev.ROBOT_FAILURE, "robot": robot})
        out.append({"t": task.t_s + 3.0, "kind": ev.TASK_OUTCOME, "task": tid,
                    "outcome": ends[i], "reason": "scripted"})
    out.sort(key=lambda e: float(e["t"]))
    return out


def _check_reports(name: str, plugin: Experiment, planned: list[PlannedTask],
                   spec: Any) -> None:
    events = _scripted_events(planned, spec)
    sections = plugin.summary_sections(events)
    rule(is_json_object(sections), name, "summary_sections() must be a JSON object")
    verdict = plugin.verdict({"end_reason": "completed", **sections})
    rule(verdict is None or isinstance(verdict, Verdict), name,
          "verdict() must give a Verdict or None")
    steps = plugin.next_steps()
    rule(isinstance(steps, list) and all(isinstance(s, str) for s in steps), name,
          "next_steps() must give a list of str")
    with tempfile.TemporaryDirectory() as tmp:
        paths = plugin.plots(events, Path(tmp))
        rule(all(Path(p).is_file() for p in paths), name,
              "plots() must give the paths of the files it wrote")


def _real_run(plugin: Experiment, seed: int, out: Path | None) -> None:
    """A few simulated minutes for real: a busy robot killed and started again; every task
    must end in exactly one terminal state."""
    from experiments.run_cli import run_experiment
    from experiments.summary import terminal_state_problems

    with tempfile.TemporaryDirectory() as tmp:
        where = out or Path(tmp)
        code = run_experiment(experiment=plugin.name, duration_s=300.0, speedup=0.0,
                              seed=seed, meshcat=False, out=where, world_name=plugin.world,
                              task_interval_s=None, kills=[("busy", 120.0)],
                              restarts=[("busy", 180.0)], replay=False, record=False)
        runs = sorted(p for p in where.iterdir() if p.is_dir())
        rule(bool(runs), plugin.name, "a real run left no run directory")
        problems: Mapping[str, Any] = terminal_state_problems(
            ev.read_events(runs[-1] / "events.jsonl"))
        rule(not any(problems.values()), plugin.name,
              f"every task must end in exactly one terminal state: {problems}")
        rule(code in (0, 4), plugin.name, f"a real run ended with exit status {code}")
