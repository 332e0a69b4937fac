"""Generated worlds ([generate]): layout from a seed, counts, determinism, swarm100, and
clear errors for bad options."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from worlds import WorldError, load_world, parse_world, world_path
from worlds.generate import kind_counts

SWARM = tomllib.loads(world_path("swarm100").read_text(encoding="utf-8"))
FILE = Path("gen.toml")


def _world(**generate: object) -> dict:
    data = copy.deepcopy(SWARM)
    data["generate"].update(generate)
    return data


def test_swarm100_has_what_the_long_term_domain_needs() -> None:
    spec = load_world(world_path("swarm100"))
    assert len(spec.robots) == 100
    assert len(spec.chargers) == 25
    assert {c.colour for c in spec.chargers} == {0x00FFFF}
    assert len(spec.objects) == 40 and len(spec.boxes) == 20
    assert len({o.colour for o in spec.objects}) == 4
    assert len({b.colour for b in spec.boxes}) == 2
    assert spec.overhead_camera is not None
    assert spec.overhead_camera.view_size_x_m == pytest.approx(spec.arena.size_x_m)
    assert spec.arena.size_x_m * spec.arena.size_y_m == pytest.approx(600.0, rel=1e-3)
    sets = [set(r.devices.names()) for r in spec.robots]
    assert sum("laser" in s for s in sets) == 34
    assert sum("bumper" in s for s in sets) == 33
    assert all({"position2d", "sonar", "camera", "blobfinder", "power"} <= s for s in sets)
    fractions = [r.devices.power.initial_fraction for r in spec.robots if r.devices.power]
    assert min(fractions) >= 0.55 and max(fractions) <= 1.0 and len(set(fractions)) > 50
    # every thing has its own slot: no two closer than the lattice allows
    pts = ([(r.pose.x, r.pose.y) for r in spec.robots] + [(c.x, c.y) for c in spec.chargers]
           + [(o.pose.x, o.pose.y) for o in spec.objects])
    nearest = min(math.dist(a, b) for i, a in enumerate(pts) for b in pts[i + 1:])
    assert nearest >= 1.5 * 0.8 - 1e-9


def test_same_seed_same_world_and_other_seeds_differ() -> None:
    a = parse_world(_world(seed=5), FILE)
    b = parse_world(_world(seed=5), FILE)
    c = parse_world(_world(seed=6), FILE)
    assert a == b
    assert [r.pose for r in a.robots] != [r.pose for r in c.robots]
    # without a seed of its own the section uses the [sim] seed
    d = copy.deepcopy(SWARM)
    d["sim"]["seed"] = 5
    assert parse_world(d, FILE).robots == a.robots


@pytest.mark.parametrize("n", [1, 7, 250, 1000])
def test_counts_and_arena_follow_the_robot_count(n: int) -> None:
    spec = parse_world(_world(robots=n, objects=n // 4, boxes=n // 10), FILE)
    assert len(spec.robots) == n
    assert len(spec.chargers) == math.ceil(n / 4)
    assert spec.arena.size_x_m == pytest.approx(max(4.0, math.sqrt(6.0 * n)), abs=1e-3)
    names = [r.name for r in spec.robots]
    assert len(set(names)) == n


def test_kind_counts_follow_the_shares() -> None:
    assert kind_counts(_kinds(1, 1, 1), 100) == [34, 33, 33]
    assert kind_counts(_kinds(3, 1), 10) == [8, 2]
    assert sum(kind_counts(_kinds(0.3, 0.3, 0.4), 7)) == 7


def _kinds(*shares: float) -> tuple:
    from worlds.generate import Kind
    return tuple(Kind(f"k{i}", s, {}) for i, s in enumerate(shares))


@pytest.mark.parametrize(("change", "key", "expected"), [
    (lambda d: d["generate"].update(robots=0), "generate.robots", "an integer >= 1"),
    (lambda d: d["generate"].update(robots=9000), "generate.robots", "<= 5000"),
    (lambda d: d["generate"].update(robotz=3), "generate.robotz", "one of the known keys"),
    (lambda d: d["generate"].update(object_colours=["red", "mauvish"]),
     "generate.object_colours", "a colour"),
    (lambda d: d["generate"]["kinds"][0]["laser"].update(samples="x"),
     "generate.kinds[0].laser.samples", "an integer"),
    (lambda d: d["generate"]["kinds"][1].update(pose=[1, 2]), "generate.kinds[1].pose",
     "the generator sets it"),
    (lambda d: d["generate"].update(kinds=[]), "generate.kinds", "at least one"),
    (lambda d: d["arena"].update(size=[3, 3]), "arena.size", "derived from generate.robots"),
    (lambda d: d.update(robots=[{"name": "a"}]), "robots", "no [[robots]]"),
    (lambda d: d["generate"].update(spacing=5.0), "generate", "at most 25 robots"),
    (lambda d: d["generate"].update(initial_charge=[0.9, 0.2]), "generate.initial_charge",
     "0 <= low <= high <= 1"),
])
def test_bad_options_name_the_option_expected_and_found(change, key: str,
                                                        expected: str) -> None:
    data = copy.deepcopy(SWARM)
    change(data)
    with pytest.raises(WorldError) as info:
        parse_world(data, FILE)
    assert info.value.key == key
    assert expected in info.value.expected
    assert str(FILE) in str(info.value)


def test_a_bad_generated_world_is_reported_without_a_traceback(tmp_path: Path) -> None:
    text = world_path("swarm100").read_text(encoding="utf-8").replace(
        "robots = 100", "robots = -3")
    bad = tmp_path / "bad_swarm.toml"
    bad.write_text(text, encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "player_server.sim", str(bad),
                          "--sim-seconds", "1"], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert "bad_swarm.toml: generate.robots: expected an integer >= 1, found -3" in (
        out.stdout + out.stderr)
    assert "Traceback" not in out.stdout + out.stderr
