"""Stage blocks as shapes: rectangles stay boxes, other polygons become polygon obstacles
(scaled into the model's size, with their z extents), and TOML worlds carry them both ways."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from worlds import WorldError, load_world
from worlds.stage import StageError, load_stage_world
from worlds.to_toml import world_to_toml

TRIANGLE_WORLD = """\
model( name "tri" pose [1 2 0 90] size [2 1 0.5] origin [0.25 0 0 0]
  block( points 3 point[0] [0 0] point[1] [4 0] point[2] [0 2] z [0.5 1] ) )
model( name "L" pose [-2 -1 0 0] size [1 1 0.4]
  block( points 6 point[0] [0 0] point[1] [2 0] point[2] [2 0.5] point[3] [0.5 0.5]
         point[4] [0.5 2] point[5] [0 2] z [0 1] )
  block( points 4 point[0] [0 0] point[1] [0.5 0] point[2] [0.5 0.5] point[3] [0 0.5]
         z [0 0.5] ) )
position( name "r" )
"""


def test_polygon_blocks_are_scaled_into_the_size_with_their_z(tmp_path: Path) -> None:
    w = tmp_path / "w.world"
    w.write_text(TRIANGLE_WORLD)
    obstacles = {o.name: o for o in load_stage_world(w).spec.arena.obstacles}
    tri = obstacles["tri"]
    assert tri.shape == "polygon"
    # the block's 4 x 2 bounds fill the 2 x 1 size, centred, then moved by the origin
    assert tri.points == ((-0.75, -0.5), (1.25, -0.5), (-0.75, 0.5))
    assert (tri.size_x_m, tri.size_y_m) == (2.0, 1.0)
    assert (tri.base_m, tri.height_m) == (0.25, 0.25)  # z [0.5 1] of the tallest 1 -> 0.5 m
    placed = tri.placed()  # turned by 90 degrees about (1, 2)
    assert placed[1] == pytest.approx((1.5, 3.25))
    l_shape, square = obstacles["L.block0"], obstacles["L.block1"]
    assert l_shape.shape == "polygon" and len(l_shape.points) == 6
    assert l_shape.points[3] == (-0.25, -0.25)
    assert square.shape == "box" and square.height_m == pytest.approx(0.2)
    assert (square.size_x_m, square.size_y_m) == (0.25, 0.25)


def test_polygon_obstacles_survive_conversion_to_toml(tmp_path: Path) -> None:
    w = tmp_path / "w.world"
    w.write_text(TRIANGLE_WORLD)
    spec = load_stage_world(w).spec
    toml = tmp_path / "w.toml"
    toml.write_text(world_to_toml(spec))
    again = load_world(toml)
    assert again.arena.obstacles == spec.arena.obstacles


def test_crossing_block_is_a_one_line_error(tmp_path: Path) -> None:
    w = tmp_path / "bad.world"
    w.write_text('model( name "x"\n  block( points 4 point[0] [0 0] point[1] [1 1] '
                 'point[2] [1 0] point[3] [0 1] ) )\n')
    with pytest.raises(StageError) as info:
        load_stage_world(w)
    msg = str(info.value)
    assert msg.startswith(f"{w}:2: expected a block whose points outline an area")
    assert "edges 0 and 2 cross" in msg and "\n" not in msg


GOOD = """\
[arena]
size = [6.0, 4.0]
[[arena.obstacles]]
name = "wedge"
shape = "polygon"
pose = [1, 0, 30]
points = [[0, 0], [1, 0], [0, 0.5]]
height = 0.4
base = 0.1
"""


def test_toml_polygon_obstacle(tmp_path: Path) -> None:
    p = tmp_path / "w.toml"
    p.write_text(GOOD)
    (ob,) = load_world(p).arena.obstacles
    assert ob.shape == "polygon" and ob.points == ((0.0, 0.0), (1.0, 0.0), (0.0, 0.5))
    assert (ob.size_x_m, ob.size_y_m, ob.height_m, ob.base_m) == (1.0, 0.5, 0.4, 0.1)
    assert ob.pose.yaw == pytest.approx(math.radians(30))


@pytest.mark.parametrize(("points", "found"), [
    ("[[0, 0], [1, 0]]", "2 points"),
    ("[[0, 0], [1, 1], [1, 0], [0, 1]]", "edges 0 and 2 cross"),
    ("[[0, 0], [1, 0], [2, 0]]", "zero area"),
    ("[[0, 0], [1, 0], [1]]", "[[0, 0], [1, 0], [1]]"),
    ("'square'", "square"),
])
def test_bad_toml_polygons_name_file_key_expected_found(tmp_path: Path, points: str,
                                                       found: str) -> None:
    p = tmp_path / "w.toml"
    p.write_text(GOOD.replace("[[0, 0], [1, 0], [0, 0.5]]", points))
    with pytest.raises(WorldError) as info:
        load_world(p)
    msg = str(info.value)
    assert info.value.key == "arena.obstacles[0].points"
    assert msg.startswith(f"{p}: arena.obstacles[0].points: expected [[x, y], ...]: 3 or more")
    assert found in msg and "\n" not in msg


DART_WORLD = """\
position( name "dart" pose [ 1 0 0 0 ] size [ 0.8 0.6 0.3 ] origin [ -0.1 0 0 0 ]
  block( points 3 point[0] [ 0 0 ] point[1] [ 4 1 ] point[2] [ 0 2 ] z [ 0 1 ] )
  block( points 4 point[0] [ 0 0.5 ] point[1] [ 0.5 0.5 ] point[2] [ 0.5 1.5 ]
         point[3] [ 0 1.5 ] z [ 0 1 ] ) )
position( name "box" pose [ -1 0 0 0 ]
  block( points 4 point[0] [ -1 -1 ] point[1] [ 1 -1 ] point[2] [ 1 1 ] point[3] [ -1 1 ] ) )
"""


def test_robot_blocks_make_a_convex_outline_that_survives_toml(tmp_path: Path) -> None:
    w = tmp_path / "w.world"
    w.write_text(DART_WORLD)
    spec = load_stage_world(w).spec
    dart, box = (r.body for r in spec.robots)
    # the hull of both blocks, scaled into 0.8 x 0.6 m about the size box's centre
    assert dart.outline == ((-0.4, -0.3), (0.4, 0.0), (-0.4, 0.3))
    assert (dart.length_m, dart.width_m, dart.offset_x_m) == (0.8, 0.6, -0.1)
    assert box.outline == ()  # a rectangular block: the size box
    toml = tmp_path / "w.toml"
    toml.write_text(world_to_toml(spec))
    assert load_world(toml).robots == spec.robots


BODY = """\
[arena]
size = [6.0, 4.0]
[[robots]]
name = "r"
pose = [0, 0]
[robots.body]
"""


def test_toml_body_outline(tmp_path: Path) -> None:
    p = tmp_path / "w.toml"
    p.write_text(BODY + "outline = [[0.3, 0], [-0.2, 0.2], [-0.2, -0.2]]\n")
    body = load_world(p).robots[0].body
    assert body.outline == ((-0.2, -0.2), (0.3, 0.0), (-0.2, 0.2))  # anticlockwise
    assert (body.length_m, body.width_m) == (0.6, 0.4)  # from the outline when not given


@pytest.mark.parametrize(("extra", "expected"), [
    ("outline = [[0, 0], [1, 0], [0.2, 0.2], [0, 1]]", "a convex outline"),
    ("outline = [[0.3, 0], [-0.2, 0.2], [-0.2, -0.2]]\nlength = 0.4", "points within"),
    ("outline = [[0, 0], [1, 1], [1, 0], [0, 1]]", "3 or more points"),
])
def test_bad_body_outlines_are_one_line(tmp_path: Path, extra: str, expected: str) -> None:
    p = tmp_path / "w.toml"
    p.write_text(BODY + extra + "\n")
    with pytest.raises(WorldError) as info:
        load_world(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}: robots[0].body.outline: expected") and expected in msg
    assert "\n" not in msg
