"""World files: bundled worlds load with the expected content; bad files give clear errors."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from worlds import WorldError, load_world, parse_colour, world_path
from worlds.pioneer import sonar_ring

BUNDLED = ("simple", "boxpush", "longterm", "test_lowbattery")


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_worlds_load(name: str) -> None:
    spec = load_world(world_path(name))
    assert spec.name == name
    assert spec.source == world_path(name)
    assert spec.robots
    assert spec.sim.interval_sim_s == pytest.approx(0.1)
    assert spec.sim.fidelity == "fast"


def test_world_path_accepts_names_and_paths(worlds_dir: Path) -> None:
    assert world_path("simple") == worlds_dir / "simple.toml"
    assert world_path(str(worlds_dir / "simple.toml")) == worlds_dir / "simple.toml"
    with pytest.raises(FileNotFoundError, match="bundled worlds"):
        world_path("no_such_world")


def test_longterm_matches_the_four_task_types() -> None:
    spec = load_world(world_path("longterm"))
    assert len(spec.robots) == 6
    sets = [set(r.devices.names()) for r in spec.robots]
    for s in sets:
        assert {"position2d", "camera", "blobfinder", "sonar", "power"} <= s
    sentry = [s for s in sets if "laser" in s]
    cleanup = [s for s in sets if "bumper" in s]
    assert len(sentry) >= 2 and len(cleanup) >= 2
    assert spec.overhead_camera is not None
    assert len(spec.chargers) >= 2
    assert len({o.colour for o in spec.objects}) == len(spec.objects) >= 3
    assert sum(1 for b in spec.boxes if b.size_x_m <= 0.4) >= 2


def test_boxpush_has_watcher_pushers_box_and_goal() -> None:
    spec = load_world(world_path("boxpush"))
    watcher = spec.robot("watcher")
    assert watcher.devices.laser is not None and watcher.devices.camera is not None
    # The watcher's laser looks back at the box; its camera forward at the goal.
    assert abs(abs(watcher.devices.laser.pose.yaw) - math.pi) < 1e-9
    for name in ("pusher1", "pusher2"):
        d = spec.robot(name).devices
        assert d.bumper is not None and d.camera is not None and d.laser is None
    big = max(spec.boxes, key=lambda b: b.size_x_m * b.size_y_m)
    assert max(big.size_x_m, big.size_y_m) >= 1.0
    goal = spec.markers[0]
    assert goal.colour not in {b.colour for b in spec.boxes} | {r.colour for r in spec.robots}
    assert goal.colour in watcher.devices.blobfinder.channels


def test_pioneer_sonar_ring_geometry() -> None:
    ring = sonar_ring()
    assert len(ring) == 16
    assert ring[0].x == pytest.approx(0.069) and ring[0].y == pytest.approx(0.136)
    assert math.degrees(ring[0].yaw) == pytest.approx(90.0)
    assert math.degrees(ring[3].yaw) == pytest.approx(10.0)
    assert math.degrees(ring[11].yaw) == pytest.approx(-170.0)
    # Left/right symmetric front array.
    for i in range(8):
        assert ring[i].x == pytest.approx(ring[7 - i].x)
        assert ring[i].y == pytest.approx(-ring[7 - i].y)


def test_default_devices_and_units() -> None:
    spec = load_world(world_path("simple"))
    d = spec.robots[0].devices
    assert d.laser.samples == 181 and d.laser.max_range_m == 8.0
    assert d.laser.resolution_rad == pytest.approx(math.radians(1.0))
    assert d.camera.fov_h_rad == pytest.approx(math.radians(60))
    assert len(d.bumper.segments) == 10
    assert d.power.sensor_w > 0
    assert spec.arena.obstacles[1].pose.yaw == pytest.approx(math.radians(30))


def test_colours() -> None:
    assert parse_colour("red") == 0xFF0000
    assert parse_colour("#00ff80") == 0x00FF80
    assert parse_colour(0x123456) == 0x123456
    with pytest.raises(ValueError):
        parse_colour("#12345")


GOOD = """
[arena]
size = [6.0, 4.0]

[[robots]]
name = "r"
pose = [0, 0, 90]
[robots.position2d]
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "w.toml"
    p.write_text(text)
    return p


def test_minimal_world_and_degrees(tmp_path: Path) -> None:
    spec = load_world(write(tmp_path, GOOD))
    assert spec.name == "w"
    assert spec.robots[0].pose.yaw == pytest.approx(math.pi / 2)
    spec2 = load_world(write(tmp_path, GOOD.replace("pose = [0, 0, 90]",
                                                    "pose = {x = 0, y = 0, yaw_rad = 1.0}")))
    assert spec2.robots[0].pose.yaw == pytest.approx(1.0)


BAD = [
    ("[arena]\n", "arena.size", "required"),
    (GOOD.replace("size = [6.0, 4.0]", "size = [6.0, -4.0]"), "arena.size", "> 0"),
    (GOOD.replace('name = "r"', "name = 3"), "robots[0].name", "a string"),
    (GOOD + "colour = 12\n", "robots[0].position2d.colour", "known keys"),
    (GOOD.replace("[robots.position2d]", "[robots.position2d]\nmax_speed = 'fast'"),
     "robots[0].position2d.max_speed", "a number"),
    (GOOD + "[robots.laser]\nmax_range = -1\n", "robots[0].laser.max_range", "> 0"),
    (GOOD + "[robots.blobfinder]\nchannels = ['red']\n", "robots[0].blobfinder",
     "[camera]"),
    (GOOD + "[robots.camera]\n[robots.blobfinder]\nchannels = ['reddish']\n",
     "robots[0].blobfinder.channels[0]", "a colour"),
    (GOOD.replace("pose = [0, 0, 90]", "pose = [9, 0, 0]"), "robots[0].pose", "inside"),
    (GOOD + '[[robots]]\nname = "r"\npose = [1, 1]\n', "robots[1].name", "unique"),
    ("[sim]\nfidelity = 'ultra'\n" + GOOD, "sim.fidelity", "'fast'"),
    (GOOD.replace("pose = [0, 0, 90]", "pose = [0, 0, 'north']"), "robots[0].pose",
     "yaw_deg"),
    ("[arena\nsize = 1", "", "valid TOML"),
    (GOOD + "[robots.sonar]\nposes = [[0, 0]]\n", "robots[0].sonar.poses[0]", "[x, y, yaw_deg]"),
    (GOOD + "[robots.power]\nvolts_empty = 14\n", "robots[0].power.volts_empty", "< volts_full"),
]


@pytest.mark.parametrize(("text", "key", "expected"), BAD)
def test_bad_worlds_name_file_key_expected_found(
    tmp_path: Path, text: str, key: str, expected: str
) -> None:
    path = write(tmp_path, text)
    with pytest.raises(WorldError) as info:
        load_world(path)
    err = info.value
    assert err.file == path
    assert err.key == key
    assert expected in err.expected
    msg = str(err)
    assert str(path) in msg and expected in msg and "found" in msg


def test_missing_file_is_a_world_error(tmp_path: Path) -> None:
    with pytest.raises(WorldError, match="readable"):
        load_world(tmp_path / "nope.toml")
