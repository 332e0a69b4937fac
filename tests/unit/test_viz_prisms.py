"""Polygon obstacles drawn as prisms: in the scene layout, the live view's meshes, the legend
and the recording's static scene."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from experiments import recording
from player_server.viz import hud, scene
from worlds import load_world

WORLD = """\
[arena]
size = [6.0, 4.0]
[[arena.obstacles]]
name = "ell"
shape = "polygon"
pose = [1, 0, 90]
points = [[0, 0], [2, 0], [2, 0.5], [0.5, 0.5], [0.5, 2], [0, 2]]
height = 0.4
base = 0.1
colour = "#336699"
"""


@pytest.fixture
def layout(tmp_path: Path) -> scene.SceneLayout:
    p = tmp_path / "w.toml"
    p.write_text(WORLD)
    return scene.layout_from_world(load_world(p))


def test_layout_places_the_outline(layout: scene.SceneLayout) -> None:
    assert layout.obstacles == () and layout.posts == ()
    (prism,) = layout.prisms
    assert (prism.name, prism.bottom_m, prism.top_m, prism.colour) == ("ell", 0.1, 0.5,
                                                                       0x336699)
    assert prism.points[1] == pytest.approx((1.0, 2.0))  # (2, 0) turned by 90 degrees
    assert math.isclose(prism.points[0][0], 1.0) and math.isclose(prism.points[0][1], 0.0)


def test_scene_and_recording_draw_the_prism(layout: scene.SceneLayout) -> None:
    cmds = {c["path"]: c for c in scene.static_scene(layout) if c["type"] == "set_object"}
    obj = cmds["/murdoch/prisms/0"]["object"]
    (geom,) = obj["geometries"]
    data = geom["data"]
    positions = data["attributes"]["position"]["array"]
    assert len(positions) == 12 * 3  # six corners, at the bottom and the top
    assert sorted(set(positions[2::3])) == pytest.approx([0.1, 0.5])
    assert len(data["index"]["array"]) == 3 * (2 * 4 + 2 * 6)  # caps and sides
    legend = hud.legend_entries(layout)
    assert "#336699" in next(e["colours"] for e in legend if e["label"] == "obstacle")
    ents = recording.static_scene(layout)["entities"]
    (ell,) = [e for e in ents if e["id"] == "obstacle/ell"]
    (tris,) = ell["triangles"]
    assert len(tris["points"]) == 12 and len(tris["indices"]) == 60


def test_a_robot_with_an_outline_is_drawn_as_its_prism(tmp_path: Path) -> None:
    p = tmp_path / "w.toml"
    p.write_text(WORLD + '[[robots]]\nname = "dart"\npose = [-2, 1]\n[robots.position2d]\n'
                 "[robots.body]\noutline = [[0.3, 0], [-0.2, 0.2], [-0.2, -0.2]]\n"
                 "offset_x = -0.05\n")
    layout = scene.layout_from_world(load_world(p))
    (robot,) = layout.robots
    assert robot.outline == ((-0.2, -0.2), (0.3, 0.0), (-0.2, 0.2))
    cmds = {c["path"]: c for c in scene.static_scene(layout) if c["type"] == "set_object"}
    body = cmds["/murdoch/robots/dart/body/idle"]["object"]
    (geom,) = body["geometries"]
    assert geom["type"] == "BufferGeometry"
    assert len(geom["data"]["attributes"]["position"]["array"]) == 6 * 3
    (ent,) = recording.robots_scene(0.0, layout, {})["entities"]
    (tris,) = ent["triangles"]
    assert [pt["x"] for pt in tris["points"][:3]] == pytest.approx([-0.25, 0.25, -0.25])
