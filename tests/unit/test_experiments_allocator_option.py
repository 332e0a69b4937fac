"""`murdoch run --allocator` and `--group-tasks`: the options, config.json and the robots'
command lines (MURDOCH's unchanged, so recorded runs and their digests stay as they were)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click
from click.testing import CliRunner

from experiments.compare import ALLOCATOR_NAMES
from experiments.plugin import RunOptions
from experiments.registry import experiments
from experiments.run_cli import run
from experiments.run_extras import RunExtras
from experiments.run_parts import RunSettings, run_config
from experiments.supervisor import BusPlace, robot_process


def _robot(allocator: str) -> list[str]:
    spec = robot_process("p1", world="longterm", bus=BusPlace(mcast_port=5000), seed=1,
                         logs=Path("/l"),
                         metric_terms=(), lockstep=True, read_timeout_s=60.0,
                         allocator=allocator)
    return list(spec.args)


def test_only_a_robot_of_another_allocator_is_told_which() -> None:
    murdoch = _robot("murdoch")
    assert "--allocator" not in murdoch
    for name in ("cbba", "cbga"):
        args = _robot(name)
        i = args.index("--allocator")
        assert args[i + 1] == name
        assert args[:i] + args[i + 2:] == murdoch


def test_the_option_offers_the_one_list_of_allocators() -> None:
    option = next(p for p in run.params if p.name == "allocator")
    assert isinstance(option.type, click.Choice)
    assert tuple(option.type.choices) == ALLOCATOR_NAMES
    assert option.default == "murdoch"
    assert [f.name for f in dataclasses.fields(RunOptions)][-2:] == ["allocator", "own"]
    assert RunOptions(60.0, 1).allocator == "murdoch"


def test_an_unknown_allocator_or_rate_is_refused_naming_the_option() -> None:
    for args, needle in ((["--allocator", "auction"], "--allocator"),
                         (["--group-tasks", "1.5"], "--group-tasks")):
        result = CliRunner().invoke(run, ["longterm", *args])
        assert result.exit_code == 2 and needle in result.output


def _settings() -> RunSettings:
    return RunSettings(experiment=experiments()["longterm"], world_name="longterm", speedup=0.0,
                       meshcat=False, out=Path("/o"), kills=(), restarts=(), replay=False,
                       pipelined=True, robot_nice=0, pin_cpus=False, key="k", trails=0,
                       lasers=False, record=False, record_rate_hz=2.0, metric_terms=(),
                       extras=RunExtras())


def test_config_records_the_allocator_and_a_group_task_rate_when_there_is_one() -> None:
    plain = run_config(_settings(), RunOptions(60.0, 1), None)
    assert plain["allocator"] == "murdoch" and "group_task_rate" not in plain
    mixed = run_config(_settings(), RunOptions(60.0, 1, own={"group_tasks": 0.25},
                                               allocator="cbga"), None)
    assert mixed["allocator"] == "cbga" and mixed["group_task_rate"] == 0.25


def test_group_tasks_are_for_the_longterm_experiment() -> None:
    result = CliRunner().invoke(run, ["boxpush", "--group-tasks", "0.5"])
    assert result.exit_code == 2
    assert "--group-tasks is an option of longterm, not of boxpush" in result.output
