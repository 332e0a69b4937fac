"""Experiments as plug-ins: the registry, what each one adds, and processes as data."""

from __future__ import annotations

from pathlib import Path

import click
import pytest

from experiments import registry
from experiments.plugin import NoReferee, RunOptions
from experiments.plugins.boxpush import BoxpushReferee
from experiments.registry import experiment, experiments
from experiments.supervisor import BusPlace, ProcessSpec, robot_process
from worlds import load_world, world_path

EXPERIMENTS = experiments()


@pytest.mark.parametrize("name", sorted(EXPERIMENTS))
def test_each_registered_experiment_runs_in_its_own_world(name: str) -> None:
    plugin = EXPERIMENTS[name]
    if True:
        assert plugin.name == name and experiment(name) is plugin
        spec = load_world(world_path(plugin.world))
        options = plugin.check(spec, RunOptions.of(plugin, 120.0, 3))
        first = next(plugin.tasks(spec, options))
        assert first is not None and first.t_s < 120.0
        assert plugin.next_steps() or name not in registry.BUILT_IN
    assert experiment("soak-of-something-else") is None and experiment(None) is None


def test_longterm_adds_nothing_of_its_own_without_group_tasks() -> None:
    plugin = EXPERIMENTS["longterm"]
    spec = load_world(world_path("longterm"))
    assert isinstance(plugin.referee(spec, RunOptions(60.0, 1)), NoReferee)
    assert plugin.config(RunOptions(60.0, 1)) == {} and plugin.faults(RunOptions(60.0, 1)) == []


def test_boxpush_resolves_its_robots_and_schedules_their_switches() -> None:
    plugin = EXPERIMENTS["boxpush"]
    spec = load_world(world_path("boxpush"))
    options = plugin.check(spec, RunOptions(90.0, 2, own={"switch_off": (("p1", 30.0),),
                                                          "switch_on": (("p1", 60.0),)}))
    assert options.own["switch_off"] == (("pusher1", 30.0),)
    assert [(f.action, f.robot, f.t_s) for f in plugin.faults(options)] == [
        ("switch-off", "pusher1", 30.0), ("switch-on", "pusher1", 60.0)]
    config = plugin.config(options)
    assert config["switch_offs"] == ["pusher1@30s"] and config["goal_radius_m"] == 2.5
    referee = plugin.referee(spec, options)
    assert isinstance(referee, BoxpushReferee)
    assert set(referee.fault_actions()) == {"switch-off", "switch-on"}
    assert len(referee.samplers) == 2
    with pytest.raises(click.BadParameter, match="no robot"):
        plugin.check(spec, RunOptions(90.0, 2, own={"switch_off": (("nobody", 30.0),)}))
    with pytest.raises(click.BadParameter, match="no marker"):
        plugin.check(spec, RunOptions(90.0, 2, own={"retarget": (("nowhere", 20.0),)}))


def test_the_goal_section_and_verdict_come_from_the_boxpush_plugin() -> None:
    plugin = EXPERIMENTS["boxpush"]
    events = [{"t": 0.0, "kind": "run_start", "experiment": "boxpush"},
              {"t": 5.0, "kind": "goal_unachievable", "task": "t1", "reason": "stuck"}]
    section = plugin.summary_sections(events)["goal"]
    assert section["unachievable"] and section["unachievable_reason"] == "stuck"
    verdict = plugin.verdict({"goal": section})
    assert verdict is not None and verdict.exit_code == 4
    assert EXPERIMENTS["longterm"].verdict({"goal": None}) is None


def test_boxpush_rounds_one_by_default_none_left_open_under_soak_and_counted() -> None:
    plugin = EXPERIMENTS["boxpush"]
    spec = load_world(world_path("boxpush"))
    assert plugin.check(spec, RunOptions.of(plugin, 90.0, 2)).get("rounds", 1) == 1
    assert "rounds" not in plugin.config(RunOptions.of(plugin, 90.0, 2))
    assert plugin.config(RunOptions.of(plugin, 90.0, 2, rounds=0))["rounds"] == 0
    assert ("rounds", 0) in plugin.supports.soak_options
    with pytest.raises(click.BadParameter, match="0 or more rounds"):
        plugin.check(spec, RunOptions.of(plugin, 90.0, 2, rounds=-1))
    events = [{"t": 0.0, "kind": "run_start", "experiment": "boxpush"},
              {"t": 200.0, "kind": "goal_reached", "box": "bigbox", "distance_m": 2.4},
              {"t": 203.0, "kind": "box_round", "round": 2, "task": "user.0.2"}]
    section = plugin.summary_sections(events)["goal"]
    assert section["rounds"] == 2 and section["arrivals"] == 1 and section["reached"]


def test_a_process_is_described_as_data_and_filled_in_at_each_start(tmp_path: Path) -> None:
    spec = robot_process("r1", world="w.toml", bus=BusPlace(mcast_port=4000), seed=7,
                         logs=tmp_path, metric_terms=("distance",), lockstep=True,
                         read_timeout_s=720.0)
    d = spec.as_dict()
    assert d["name"] == "r1" and d["restart"] == "on-schedule" and "{port}" in d["args"]
    argv = spec.argv(port=6001, instance=2)
    assert argv[:len(spec.command)] == list(spec.command)
    rest = argv[len(spec.command):]
    assert rest[rest.index("-p") + 1] == "6001" and rest[rest.index("--instance") + 1] == "2"
    assert rest[rest.index("--metric") + 1] == "distance" and "--lockstep-bus" in rest
    assert rest[rest.index("-h") + 1] == "127.0.0.1"
    assert rest[rest.index("--mcast-port") + 1] == "4000" and "--transport" not in rest
    with pytest.raises(ValueError, match="restart must be one of"):
        ProcessSpec("x", ("true",), (), restart="always")


def test_a_robot_placed_elsewhere_is_launched_through_its_prefix_and_joins_over_zenoh(
    tmp_path: Path,
) -> None:
    bus = BusPlace(server_host="10.199.0.1", zenoh_endpoint="tcp/10.199.0.1:7500")
    spec = robot_process("r2", world="w.toml", bus=bus, seed=1, logs=tmp_path,
                         metric_terms=(), lockstep=False, read_timeout_s=60.0,
                         launch=("ip", "netns", "exec", "robots"))
    argv = spec.argv(port=6002, instance=0)
    assert argv[:4] == ["ip", "netns", "exec", "robots"]
    assert argv[4:4 + len(spec.command)] == list(spec.command)
    rest = argv[4 + len(spec.command):]
    assert rest[rest.index("-h") + 1] == "10.199.0.1"
    assert rest[rest.index("--transport") + 1] == "zenoh"
    assert rest[rest.index("--zenoh-endpoint") + 1] == "tcp/10.199.0.1:7500"
    assert "--zenoh-allow-remote" in rest and "--mcast-port" not in rest
    assert spec.as_dict()["launch"] == ["ip", "netns", "exec", "robots"]
def test_boxpush_refuses_an_allocator_whose_robots_offer_no_sub_tasks() -> None:
    from experiments.run_tasks import check_supports, supported_allocators

    boxpush = EXPERIMENTS["boxpush"]
    able = supported_allocators(boxpush)
    assert "murdoch" in able and "cbga" not in able
    with pytest.raises(click.BadParameter, match=r"sub-tasks.*found cbga"):
        check_supports(boxpush, "cbga")
    check_supports(boxpush, "murdoch")
