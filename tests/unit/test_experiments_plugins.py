"""Experiments as plug-ins: the registry, what each one adds, and processes as data."""

from __future__ import annotations

from pathlib import Path

import click
import pytest

from experiments import boxpush as bp
from experiments.experiment import NoReferee, RunOptions
from experiments.plugins import EXPERIMENTS, experiment
from experiments.plugins.boxpush import BoxpushReferee
from experiments.supervisor import ProcessSpec, robot_process
from worlds import load_world, world_path


def test_each_registered_experiment_runs_in_its_own_world() -> None:
    assert set(EXPERIMENTS) == {"longterm", "boxpush"}
    for name, plugin in EXPERIMENTS.items():
        assert plugin.name == name and experiment(name) is plugin
        spec = load_world(world_path(plugin.world))
        options = plugin.check(spec, RunOptions(duration_s=120.0, seed=3))
        first = next(plugin.tasks(spec, options))
        assert first is not None and first.t_s < 120.0
        assert plugin.next_steps()
    assert experiment("soak-of-something-else") is None and experiment(None) is None


def test_longterm_refuses_the_boxpush_options() -> None:
    plugin = EXPERIMENTS["longterm"]
    spec = load_world(world_path("longterm"))
    with pytest.raises(click.UsageError, match="for the boxpush experiment"):
        plugin.check(spec, RunOptions(60.0, 1, switch_offs=(("p1", 10.0),)))
    with pytest.raises(click.UsageError, match="for the boxpush experiment"):
        plugin.check(spec, RunOptions(60.0, 1, goal_plan=bp.GoalPlan((0.0, -0.01))))
    assert isinstance(plugin.referee(spec, RunOptions(60.0, 1)), NoReferee)
    assert plugin.config(RunOptions(60.0, 1)) == {} and plugin.faults(RunOptions(60.0, 1)) == []


def test_boxpush_resolves_its_robots_and_schedules_their_switches() -> None:
    plugin = EXPERIMENTS["boxpush"]
    spec = load_world(world_path("boxpush"))
    options = plugin.check(spec, RunOptions(90.0, 2, switch_offs=(("p1", 30.0),),
                                            switch_ons=(("p1", 60.0),)))
    assert options.switch_offs == (("pusher1", 30.0),)
    assert [(f.action, f.robot, f.t_s) for f in plugin.faults(options)] == [
        ("switch-off", "pusher1", 30.0), ("switch-on", "pusher1", 60.0)]
    config = plugin.config(options)
    assert config["switch_offs"] == ["pusher1@30s"] and config["goal_radius_m"] == 2.5
    referee = plugin.referee(spec, options)
    assert isinstance(referee, BoxpushReferee)
    assert set(referee.fault_actions()) == {"switch-off", "switch-on"}
    assert len(referee.samplers) == 2
    with pytest.raises(click.BadParameter, match="no robot"):
        plugin.check(spec, RunOptions(90.0, 2, switch_offs=(("nobody", 30.0),)))
    with pytest.raises(click.BadParameter, match="no marker"):
        plugin.check(spec, RunOptions(90.0, 2, goal_plan=bp.GoalPlan(
            retargets=((20.0, "nowhere"),))))


def test_the_goal_section_and_verdict_come_from_the_boxpush_plugin() -> None:
    plugin = EXPERIMENTS["boxpush"]
    events = [{"t": 0.0, "kind": "run_start", "experiment": "boxpush"},
              {"t": 5.0, "kind": "goal_unachievable", "task": "t1", "reason": "stuck"}]
    section = plugin.summary_sections(events)["goal"]
    assert section["unachievable"] and section["unachievable_reason"] == "stuck"
    verdict = plugin.verdict({"goal": section})
    assert verdict is not None and verdict.exit_code == 4
    assert EXPERIMENTS["longterm"].verdict({"goal": None}) is None


def test_a_process_is_described_as_data_and_filled_in_at_each_start(tmp_path: Path) -> None:
    spec = robot_process("r1", world="w.toml", mcast_port=4000, seed=7, logs=tmp_path,
                         metric_terms=("distance",), lockstep=True, read_timeout_s=720.0)
    d = spec.as_dict()
    assert d["name"] == "r1" and d["restart"] == "on-schedule" and "{port}" in d["args"]
    argv = spec.argv(port=6001, instance=2)
    assert argv[:len(spec.command)] == list(spec.command)
    rest = argv[len(spec.command):]
    assert rest[rest.index("-p") + 1] == "6001" and rest[rest.index("--instance") + 1] == "2"
    assert rest[rest.index("--metric") + 1] == "distance" and "--lockstep-bus" in rest
    with pytest.raises(ValueError, match="restart must be one of"):
        ProcessSpec("x", ("true",), (), restart="always")


def test_boxpush_refuses_an_allocator_whose_robots_offer_no_sub_tasks() -> None:
    spec = load_world(world_path("boxpush"))
    with pytest.raises(click.BadParameter, match="expected one of murdoch, found cbga"):
        EXPERIMENTS["boxpush"].check(spec, RunOptions(60.0, 1, allocator="cbga"))
    assert EXPERIMENTS["boxpush"].check(spec, RunOptions(60.0, 1)).allocator == "murdoch"
