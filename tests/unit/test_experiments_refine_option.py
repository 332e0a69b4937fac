"""`--refine` from the command lines to the robots: murdoch-robot, murdoch run (the robots'
process description, config.json) and murdoch compare (`cbba+refine`); refused, naming the
option, with MURDOCH."""

from __future__ import annotations

from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from behaviors.__main__ import main as robot_main
from experiments.compare import Job, parse_allocators
from experiments.plugin import RunOptions
from experiments.registry import experiments
from experiments.run_cli import run
from experiments.run_extras import RunExtras
from experiments.run_parts import RunSettings, run_config
from experiments.supervisor import BusPlace, robot_process


def _robot(allocator: str, refine: bool) -> list[str]:
    spec = robot_process("p1", world="longterm", bus=BusPlace(mcast_port=5000), seed=1,
                         logs=Path("/l"), metric_terms=(), lockstep=True, read_timeout_s=60.0,
                         allocator=allocator, refine=refine)
    return list(spec.args)


def test_a_refined_robot_is_told_so_and_a_plain_one_as_before() -> None:
    plain = _robot("cbba", refine=False)
    refined = _robot("cbba", refine=True)
    assert "--refine" not in plain
    i = refined.index("--refine")
    assert refined[i - 2:i] == ["--allocator", "cbba"]
    assert refined[:i] + refined[i + 1:] == plain


def test_murdoch_robot_refuses_refine_with_murdoch(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        robot_main(["-p", "1", "--allocator", "murdoch", "--refine"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--refine is for the consensus allocators (cbba, cbga)" in err
    assert "Traceback" not in err


def test_murdoch_run_refuses_refine_with_murdoch() -> None:
    result = CliRunner().invoke(run, ["longterm", "--refine"])
    assert result.exit_code == 2
    assert "--refine" in result.output and "not --allocator murdoch" in result.output


def _settings(refine: bool) -> RunSettings:
    return RunSettings(experiment=experiments()["longterm"], world_name="longterm", speedup=0.0,
                       meshcat=False, out=Path("/o"), kills=(), restarts=(), replay=False,
                       pipelined=True, robot_nice=0, pin_cpus=False, key="k", trails=0,
                       lasers=False, record=False, record_rate_hz=2.0, metric_terms=(),
                       extras=RunExtras(), refine=refine)


def test_config_records_refine_on_and_off() -> None:
    options = RunOptions(60.0, 1, allocator="cbga")
    assert run_config(_settings(False), options, None)["refine"] is False
    assert run_config(_settings(True), options, None)["refine"] is True


def test_compare_takes_refined_forms_by_name_or_by_flag() -> None:
    assert parse_allocators("cbba,cbba+refine") == ["cbba", "cbba+refine"]
    assert parse_allocators("murdoch,cbga", refine=True) == ["murdoch", "cbga", "cbga+refine"]
    with pytest.raises(click.BadParameter, match="cbga\\+refine"):
        parse_allocators("murdoch+refine")
    assert Job("cbga+refine", 2).allocator_args() == ["--allocator", "cbga", "--refine"]
    assert Job("cbga", 2).allocator_args() == ["--allocator", "cbga"]
    assert Job("cbga+refine", 2).label() == "cbga+refine-s2"
