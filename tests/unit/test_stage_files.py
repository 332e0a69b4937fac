"""Stage world and Player .cfg files: syntax, definitions, conversion, errors with file:line."""

from __future__ import annotations

import logging
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from worlds import load_world
from worlds.loader import parse_world
from worlds.player_cfg import Address, load_player_cfg, parse_address
from worlds.player_plan import plan_from_cfg
from worlds.stage import StageError, Warnings, load_stage_world
from worlds.stage.bitmap import Rect, merge_runs
from worlds.stage.syntax import Where, parse_text
from worlds.to_toml import world_to_toml

ROOT = Path(__file__).resolve().parents[2]


def _write(d: Path, name: str, text: str) -> Path:
    p = d / name
    p.write_text(text)
    return p


def test_tokens_comments_strings_arrays_and_entities_on_one_line() -> None:
    doc = parse_text('# a comment\nspeedup 2.5 # trailing\n'
                     'model( color "purple" size [0.1 0.05 0.25] pose [ -1 2e-1 0 +90 ] )\n',
                     Path("w.world"))
    assert [(p.key, p.values) for p in doc.props] == [("speedup", (2.5,))]
    (m,) = doc.entities
    assert m.kind == "model" and m.where == Where(Path("w.world"), 3)
    assert {p.key: p.values for p in m.props} == {
        "color": ("purple",), "size": (0.1, 0.05, 0.25), "pose": (-1.0, 0.2, 0.0, 90.0)}


def test_define_chains_inherit_override_and_give_children_to_every_instance(
        tmp_path: Path) -> None:
    _write(tmp_path, "bits.inc", 'define base position ( size [0.5 0.4 0.3] color "red"\n'
           '  ranger( sensor( range [0 4] fov 180 samples 181 ) ) )\n')
    w = _write(tmp_path, "w.world", 'include "bits.inc"\n'
               'define bot base ( color "green" )\n'
               'bot( name "a" pose [1 0 0 0] )\n'
               'bot( name "b" pose [0 1 0 90] color "blue" )\n')
    world = load_stage_world(w)
    a, b = world.spec.robots
    assert (a.colour, b.colour) == (0x00FF00, 0x0000FF)
    assert a.body.length_m == pytest.approx(0.5)
    assert b.pose.yaw == pytest.approx(math.pi / 2)
    for r in (a, b):
        assert r.devices.laser is not None and r.devices.laser.samples == 181
        assert r.devices.laser.max_range_m == pytest.approx(4.0)
    assert [x.role for x in world.rangers["a"]] == ["laser"]


def test_units_sonar_arrays_and_odometry(tmp_path: Path) -> None:
    w = _write(tmp_path, "w.world", 'unit_length "cm"\nunit_angle "radians"\n'
               'position( name "r" pose [100 -50 0 1.5] size [44 38 22] localization "odom"\n'
               '  odom_error [0.05 0.04 0 0.1]\n'
               '  ranger( sensor( pose [10 0 0 0] range [0 500] fov 0.26 )\n'
               '          sensor( pose [0 10 0 1.57] range [0 500] fov 0.26 ) ) )\n')
    (r,) = load_stage_world(w).spec.robots
    assert (r.pose.x, r.pose.y, r.pose.yaw) == pytest.approx((1.0, -0.5, 1.5))
    assert r.body.width_m == pytest.approx(0.38)
    assert r.devices.sonar is not None and len(r.devices.sonar.poses) == 2
    assert r.devices.sonar.max_range_m == pytest.approx(5.0)
    assert r.devices.sonar.poses[1].yaw == pytest.approx(1.57)
    p = r.devices.position2d
    assert p is not None and (p.odom_noise_fraction, p.odom_yaw_noise_fraction) == (0.05, 0.1)


def test_floorplan_bitmap_becomes_merged_wall_boxes_scaled_to_its_size(tmp_path: Path) -> None:
    from PIL import Image

    img = np.full((20, 40), 255, dtype=np.uint8)
    img[0:10, 5] = 0  # a vertical wall, 10 px tall
    img[15, 10:30] = 30  # a horizontal one
    Image.fromarray(img, mode="L").save(tmp_path / "map.png")
    w = _write(tmp_path, "w.world",
               'model( name "m" bitmap "map.png" size [8 4 1] pose [1 0 0 0] )\n')
    obstacles = load_stage_world(w).spec.arena.obstacles
    assert len(obstacles) == 2  # each run merged into one box
    v, h = sorted(obstacles, key=lambda o: o.size_y_m, reverse=True)
    assert (v.size_x_m, v.size_y_m, v.height_m) == pytest.approx((0.2, 2.0, 1.0))
    assert (v.pose.x, v.pose.y) == pytest.approx((1 - 4 + 5.5 * 0.2, 2 - 1.0))
    assert (h.size_x_m, h.size_y_m) == pytest.approx((4.0, 0.2))
    assert (h.pose.x, h.pose.y) == pytest.approx((1 - 4 + 20 * 0.2, 2 - 15.5 * 0.2))


def test_merge_runs_covers_exactly_the_solid_pixels() -> None:
    rng = np.random.default_rng(4)
    solid = rng.random((30, 25)) < 0.3
    solid[5:15, 3:9] = True
    cover = np.zeros_like(solid, dtype=int)
    for r in merge_runs(solid):
        cover[r.row:r.row + r.rows, r.col:r.col + r.cols] += 1
    assert (cover == solid.astype(int)).all()
    assert merge_runs(np.ones((4, 3), dtype=bool)) == [Rect(0, 0, 4, 3)]


def test_pucks_chargers_zones_blocks_and_ctrl(tmp_path: Path,
                                              caplog: pytest.LogCaptureFixture) -> None:
    w = _write(tmp_path, "w.world",
               'model( name "puck" pose [1 1 0 0] size [0.1 0.1 0.1] gripper_return 1 '
               'fiducial_return 7 color "orange" )\n'
               'model( name "dock" pose [2 0 0 0] size [0.3 0.6 0.3] give_watts 250 )\n'
               'model( name "zone" pose [-2 0 0 0] size [1 1 0.01] obstacle_return 0 )\n'
               'model( name "L" pose [0 -2 0 0] size [2 2 1]\n'
               '  block( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 0.2] '
               'point[3] [0 0.2] z [0 1] )\n'
               '  block( points 4 point[0] [0 0] point[1] [0.2 0] point[2] [0.2 1] '
               'point[3] [0 1] z [0 0.5] ) )\n'
               'position( name "r" ctrl "wander" )\n')
    with caplog.at_level(logging.WARNING):
        world = load_stage_world(w)
    s = world.spec
    (puck,) = s.objects
    assert (puck.fiducial_id, puck.colour, puck.radius_m) == (7, 0xFF8000, 0.05)
    (dock,) = s.chargers
    assert dock.rate_w == 250 and dock.radius_m > 0.3
    assert world.fixed["zone"] == (-2.0, 0.0, 0.0)
    blocks = [o for o in s.arena.obstacles if o.name.startswith("L.block")]
    got = [v for b in blocks for v in (b.size_x_m, b.size_y_m, b.height_m)]
    assert got == pytest.approx([2.0, 0.4, 1.0, 0.4, 2.0, 0.5])
    assert sum("ctrl" in m for m in world.warnings) == 1


def test_take_watts_models_are_drains_and_survive_conversion_to_toml(tmp_path: Path) -> None:
    from worlds.to_toml import world_to_toml

    w = _write(tmp_path, "w.world",
               'model( name "sink" pose [1 2 0 30] size [0.4 0.2 0.3] take_watts 500 )\n'
               'model( name "dock" pose [2 0 0 0] size [0.3 0.6 0.3] give_watts 250 )\n'
               'position( name "r" )\n')
    s = load_stage_world(w).spec
    sink, dock = s.chargers
    assert (sink.rate_w, sink.take_w, sink.size_x_m, sink.size_y_m) == (0.0, 500.0, 0.4, 0.2)
    assert sink.yaw == pytest.approx(math.radians(30.0))
    assert (dock.rate_w, dock.take_w, dock.size_x_m) == (250.0, 0.0, 0.3)
    toml = tmp_path / "w.toml"
    toml.write_text(world_to_toml(s))
    again = load_world(toml).chargers
    assert [(c.name, c.rate_w, c.take_w, c.size_x_m, c.size_y_m) for c in again] == [
        (c.name, c.rate_w, c.take_w, c.size_x_m, c.size_y_m) for c in s.chargers]
    assert again[0].yaw == pytest.approx(sink.yaw)
    bad = _write(tmp_path, "bad.world", 'model( name "m" take_watts -1 )\n')
    with pytest.raises(StageError, match=r"bad\.world:1: expected take_watts >= 0"):
        load_stage_world(bad)


def test_unknown_keys_and_kinds_are_warned_once_with_file_and_line(tmp_path: Path) -> None:
    w = _write(tmp_path, "w.world", 'model( name "a" frobnicate 3 )\n'
               'model( name "b" frobnicate 3 )\nwidget( name "c" )\nwidget( name "d" )\n'
               'window( size [1 1] )\nthreads 2\nshow_clock 1\ninterval_real 100\n'
               'quit_time 60\nspeedup 0\nresolution 0.02\nsomething 1\n')
    warnings = Warnings()
    load_stage_world(w, warnings=warnings)
    said = " | ".join(warnings.said)
    assert f"{w}:1: key 'frobnicate'" in said and f"{w}:2: key 'frobnicate'" in said
    assert sum("widget" in m for m in warnings.said) == 1
    assert f"{w}:3: unknown model kind 'widget'" in said
    assert f"{w}:12: key 'something' of the world" in said
    assert len(warnings.said) == 4  # the global keys Stage has are accepted silently


@pytest.mark.parametrize(("text", "line", "expected"), [
    ('model( name "a"\n size [1 2 \n', 3, "expected a number, a quoted string or [ ... ]"),
    ('speedup 1\nmodel( name "a" size [1 2 3] ) )\n', 2, "expected a key, an entity"),
    ('\n\ninclude "missing.inc"\n', 3, "expected an include file that can be read"),
    ('model( name "m" bitmap "nowhere.png" size [4 4 1] )\n', 1,
     "expected a readable bitmap image"),
    ('position( name "r"\n drive "omni" )\n', 2, 'expected drive "diff"'),
    ('model( name "a" size [1 2 3 4 5] )\n', 1, "expected [ 2 to 3 numbers ] for size"),
    ('model( name "a" )\nmodel( name "a" )\n', 2, "expected a model name not used before"),
    ('speedup "fast"\n', 1, "expected one number for speedup"),
    ('model( name "a" color 3 @ )\n', 1, "expected a word, number, string"),
    ('position( name "r"\n ranger( sensor( range [5 1] ) ) )\n', 2, "expected a sensor with"),
    ('position( name "r" joules 10 joules_capacity -5 )\n', 1, "expected a positive"),
    ('model( name "a"\n pose [1e999 0 0 0] )\n', 2, "expected finite numbers for pose"),
])
def test_malformed_worlds_name_file_line_expected_and_found(tmp_path: Path, text: str,
                                                            line: int, expected: str) -> None:
    w = _write(tmp_path, "bad.world", text)
    with pytest.raises(StageError) as info:
        load_stage_world(w)
    msg = str(info.value)
    assert msg.startswith(f"{w}:{line}: {expected}"), msg
    assert "found" in msg and "\n" not in msg


def test_cfg_addresses_and_blocks(tmp_path: Path) -> None:
    at = Where(Path("x.cfg"), 1)
    assert parse_address("laser:0", 7000, at) == Address(7000, "laser", 0)
    assert parse_address("6666:ranger:1", 7000, at) == Address(6666, "ranger", 1)
    assert parse_address("localhost:6666:ranger:1", 7000, at) == Address(6666, "ranger", 1)
    assert parse_address("odometry:::position2d:0", 7000, at) == Address(7000, "position2d", 0)
    for bad in ("laser", "laser:x", "x:laser:0", "far.example:6665:laser:0"):
        with pytest.raises(StageError):
            parse_address(bad, 7000, at)
    _write(tmp_path, "w.world", 'position( name "r0" ranger( sensor( samples 1 ) '
           'sensor( samples 1 ) ) ranger( sensor( samples 90 fov 90 ) ) )\n')
    cfg_path = _write(tmp_path, "x.cfg",
                      'driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
                      'driver( name "stage" model "r0" provides ["position2d:0" "ranger:0" '
                      '"ranger:1"] )\n'
                      'driver( name "rangertolaser" requires ["ranger:1"] provides '
                      '["laser:0"] )\n'
                      'driver( name "vfh" provides ["position2d:1"] )\n'
                      'driver( name "stage" model "r0" provides ["graphics2d:0"] )\n')
    warnings = Warnings()
    cfg = load_player_cfg(cfg_path, 6700, warnings)
    world = load_stage_world(tmp_path / "w.world")
    plan = plan_from_cfg(cfg, world, warnings)
    assert [(str(b.address), b.device) for b in plan.bindings] == [
        ("6700:simulation:0", "simulation"), ("6700:position2d:0", "position2d"),
        ("6700:ranger:0", "sonar_ranger"), ("6700:ranger:1", "laser_ranger"),
        ("6700:laser:0", "laser")]
    assert any("driver 'vfh' is not provided here" in w for w in warnings.said)
    assert any("x.cfg:5: interface 'graphics2d' is not provided here; 6700:graphics2d:0 "
               "skipped" in w for w in warnings.said)


@pytest.mark.parametrize(("cfg", "expected"), [
    ('driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
     'driver( name "stage" provides ["position2d:0"] )\n',
     'x.cfg:2: expected model "NAME" in the stage driver providing 6665:position2d:0'),
    ('driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
     'driver( name "stage" model "ghost" provides ["position2d:0"] )\n',
     "x.cfg:2: expected model 'ghost' to be a position model"),
    ('driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
     'driver( name "stage" model "r0" provides ["ranger:3"] )\n',
     "x.cfg:2: expected ranger:3 among the 1 ranger(s) of model 'r0'"),
    ('driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
     'driver( name "stage" model "r0" provides ["gripper:0"] )\n',
     "x.cfg:2: expected a gripper on model 'r0'"),
    ('driver( name "stage" provides ["simulation:0"] worldfile "w.world" )\n'
     'driver( name "rangertolaser" requires ["ranger:0"] provides ["laser:0"] )\n',
     "x.cfg:2: expected 6665:ranger:0 provided above"),
    ('driver( provides ["simulation:0"] worldfile "w.world" )\n',
     'x.cfg:1: expected a name "..." in the driver block'),
])
def test_bad_cfg_blocks_name_file_line(tmp_path: Path, cfg: str, expected: str) -> None:
    _write(tmp_path, "w.world", 'position( name "r0" ranger( sensor( samples 9 ) ) )\n')
    path = _write(tmp_path, "x.cfg", cfg)
    with pytest.raises(StageError) as info:
        c = load_player_cfg(path, 6665)
        plan_from_cfg(c, load_stage_world(tmp_path / "w.world"), Warnings())
    assert str(info.value).startswith(f"{tmp_path}/{expected}"), str(info.value)


def test_shipped_world_converts_to_toml_and_back_to_the_same_spec() -> None:
    spec = load_world(ROOT / "worlds" / "stage" / "pioneers.world")
    again = parse_world(tomllib.loads(world_to_toml(spec)), spec.source)
    assert again == spec
    assert [r.name for r in spec.robots] == ["robot1", "robot2"]
    r1 = spec.robots[0].devices
    assert None not in (r1.sonar, r1.laser, r1.blobfinder, r1.gripper, r1.power)
    assert len(spec.objects) == 3 and len(spec.chargers) == 1
