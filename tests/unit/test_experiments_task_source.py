"""The long-term task generator and the runner's option parsing (pure)."""

from __future__ import annotations

import itertools
import random

import click
import pytest

from experiments.run_cli import parse_at, parse_duration_s, parse_place
from experiments.task_source import LONGTERM_KINDS, longterm_tasks
from worlds import load_world, world_path


def test_generator_is_seeded_and_ordered() -> None:
    world = load_world(world_path("longterm"))
    a = list(itertools.islice(longterm_tasks(world, random.Random(3)), 200))
    b = list(itertools.islice(longterm_tasks(world, random.Random(3)), 200))
    c = list(itertools.islice(longterm_tasks(world, random.Random(4)), 200))
    assert a == b and a != c
    assert all(x.t_s <= y.t_s for x, y in itertools.pairwise(a))
    assert {t.kind for t in a} == set(LONGTERM_KINDS)
    object_colours = {f"#{o.colour:06x}" for o in world.objects}
    box_colours = {f"#{b.colour:06x}" for b in world.boxes}
    for t in a:
        assert 60.0 <= t.params["duration_s"] <= 240.0
        if t.kind in ("object-tracking", "sentry-duty"):
            assert t.params["colour"] in object_colours
        elif t.kind == "cleanup":
            assert t.params["colour"] in box_colours
    mean_gap = (a[-1].t_s - a[0].t_s) / (len(a) - 1)
    assert 150.0 < mean_gap < 350.0  # mean interval 240 s


def test_generator_skips_monitoring_without_an_overhead_camera() -> None:
    world = load_world(world_path("boxpush"))
    kinds = {t.kind for t in itertools.islice(longterm_tasks(world, random.Random(1)), 100)}
    assert "monitor-object" not in kinds


def test_durations_and_times() -> None:
    assert parse_duration_s("90m") == 5400.0
    assert parse_duration_s("2h") == 7200.0
    assert parse_duration_s("45") == 45.0
    assert parse_at("p3@30m") == ("p3", 1800.0)
    for bad in ("soon", "5d", ""):
        with pytest.raises(click.BadParameter):
            parse_duration_s(bad)
    with pytest.raises(click.BadParameter):
        parse_at("p3")


def test_placements_are_a_robot_and_a_command_prefix() -> None:
    assert parse_place("p2=ip netns exec robots") == ("p2", ("ip", "netns", "exec", "robots"))
    assert parse_place("p3=ssh 'lab host'") == ("p3", ("ssh", "lab host"))
    for bad in ("p2", "=ssh x", "p2=", "p2=ssh 'open"):
        with pytest.raises(click.BadParameter, match="ROBOT=COMMAND PREFIX"):
            parse_place(bad)


def test_the_default_task_rate_grows_with_a_team_bigger_than_the_papers() -> None:
    from experiments.task_source import team_task_interval_s
    from worlds import load_world, world_path

    assert team_task_interval_s(load_world(world_path("longterm"))) == 240.0
    assert team_task_interval_s(load_world(world_path("boxpush"))) == 240.0  # fewer: as many
    assert team_task_interval_s(load_world(world_path("swarm100"))) == pytest.approx(14.4)
