"""The meshcat scene as plain commands: paths, matrices, state bodies, labels, world layout."""

from __future__ import annotations

import math

import pytest
import umsgpack

from player_server.viz import hud, scene
from player_server.viz.live import LiveView, body_poses
from worlds import load_world, world_path


def test_pose_matrix_is_column_major_rotation_then_translation() -> None:
    m = scene.pose_matrix(1.0, 2.0, 0.5, math.pi / 2)
    # x axis maps to +y, translation in the last column
    assert m[0:3] == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)
    assert m[4:7] == pytest.approx([-1.0, 0.0, 0.0], abs=1e-12)
    assert m[12:15] == [1.0, 2.0, 0.5]
    q = scene.yaw_quaternion_xyzw(math.pi / 2)
    assert q == pytest.approx([0, 0, math.sqrt(0.5), math.sqrt(0.5)])


def test_layout_of_every_shipped_world() -> None:
    for name in ("simple", "boxpush", "longterm"):
        spec = load_world(world_path(name))
        layout = scene.layout_from_world(spec)
        assert len(layout.walls) == 4
        assert {r.name for r in layout.robots} == {r.name for r in spec.robots if r.mobile}
        assert {c.name for c in layout.chargers} == {c.name for c in spec.chargers}
        assert layout.floor_colour == spec.arena.floor_colour
        paths = layout.body_paths()
        for b in spec.boxes:
            assert paths[b.name] == f"/murdoch/boxes/{b.name}"


def test_static_scene_draws_every_thing_once_with_idle_robots() -> None:
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    cmds = scene.static_scene(layout)
    objects = [c["path"] for c in cmds if c["type"] == "set_object"]
    assert len(objects) == len(set(objects))
    for r in layout.robots:
        for state in scene.ROBOT_STATES:
            assert f"/murdoch/robots/{r.name}/body/{state}" in objects
    visible = {c["path"]: c["value"] for c in cmds if c.get("property") == "visible"}
    r0 = scene.robot_path(layout.robots[0].name)
    assert visible[f"{r0}/body/idle"] is True and visible[f"{r0}/body/working"] is False
    for c in layout.chargers:
        assert f"/murdoch/chargers/{c.name}" in objects
    # the same scene gives the same bytes (deterministic ids), and it packs as msgpack
    again = scene.static_scene(layout)
    assert umsgpack.packb(cmds) == umsgpack.packb(again)


def test_state_change_and_labels() -> None:
    cmds = scene.state_change("p1", "idle", "charging")
    assert [(c["path"].rsplit("/", 1)[1], c["value"]) for c in cmds] == [
        ("idle", False),
        ("charging", True),
    ]
    assert len(scene.state_change("p1", None, "working")) == len(scene.ROBOT_STATES)
    with pytest.raises(ValueError, match="unknown robot state"):
        scene.state_change("p1", "idle", "dancing")


class RecordingSink:
    def __init__(self) -> None:
        self.commands: list[dict] = []

    def send(self, command: dict) -> None:
        self.commands.append(command)


def test_live_view_sends_only_what_changed() -> None:
    layout = scene.layout_from_world(load_world(world_path("simple")))
    robot = layout.robots[0].name
    sink = RecordingSink()
    view = LiveView(layout, sink)
    first = view.publish_once()
    # the scene, the legend, every robot's label block and the clock
    assert first == len(scene.static_scene(layout)) + 1 + len(layout.robots) + 1
    assert sink.commands[-1]["path"] == f"{scene.ROOT}/hud/clock"
    assert view.publish_once() == 0  # nothing new
    view.offer({robot: (1.0, 1.0, 0.0)})
    view.offer({robot: (1.0, 2.0, 0.0)})  # replaces the unsent one
    sink.commands.clear()
    assert view.publish_once() == 1
    assert sink.commands[0]["matrix"][12:14] == [1.0, 2.0]
    view.offer({robot: (1.0005, 2.0, 0.0)})  # below the move threshold
    assert view.publish_once() == 0
    view.set_robot(robot, scene.WORKING, "goto t1")
    sink.commands.clear()
    view.publish_once()
    kinds = [(c["type"], c["path"].rsplit("/", 1)[-1]) for c in sink.commands]
    assert kinds == [("set_property", "idle"), ("set_property", "working"), ("set_object", "info")]
    view.set_robot("ghost", scene.IDLE)  # not in the scene: ignored
    assert view.publish_once() == 0
    with pytest.raises(ValueError):
        view.set_robot(robot, "asleep")
    assert view.stats().snapshots_replaced == 1


def test_body_poses_accepts_snapshot_shapes() -> None:
    class Snap:
        bodies = (("p1", "robot", 1.0, 2.0, 0.5),)

    assert body_poses(Snap()) == {"p1": (1.0, 2.0, 0.5)}

    class Body:
        name, x, y, yaw = "b", 3.0, 4.0, 0.0

    class Snap2:
        bodies = (Body(),)

    assert body_poses(Snap2()) == {"b": (3.0, 4.0, 0.0)}


def _data(commands: list[dict]) -> dict[str, dict]:
    return {c["path"]: c["object"]["object"]["userData"] for c in commands
            if c["type"] == "set_object" and c["object"]["object"].get("name") == hud.DATA_NAME}


def test_live_scene_has_a_legend_labels_a_clock_and_batteries() -> None:
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    sink = RecordingSink()
    view = LiveView(layout, sink)
    view.publish_once()
    data = _data(sink.commands)
    labels = [e["label"] for e in data[f"{scene.ROOT}/hud/legend"]["entries"]]
    assert labels[:4] == ["robot idle", "robot working", "robot charging", "robot down"]
    for thing in ("heading (front of a robot)", "charging pad", "box", "object (ball, cylinder)",
                  "obstacle", "wall"):
        assert thing in labels
    for r in layout.robots:
        info = data[f"{scene.robot_path(r.name)}/info"]
        assert (info["name"], info["state"], info["battery"], info["task"]) == (
            r.name, scene.IDLE, None, "")
    assert data[f"{scene.ROOT}/hud/clock"]["text"] == "sim 0:00:00"

    class Snap:
        time_s = 3725.4
        bodies = ()

    sink.commands.clear()
    view.offer(Snap())
    view.set_battery("p1", 83.4)
    view.set_robot("p1", scene.WORKING, "cleanup: orange box", 0xFF8000)
    view.publish_once()
    data = _data(sink.commands)
    assert data[f"{scene.ROOT}/hud/clock"] == {"murdoch": "clock", "t": 3725.4,
                                               "text": "sim 1:02:05"}
    assert sink.commands[-1]["path"] == f"{scene.ROOT}/hud/clock"  # the clock closes a frame
    info = data[f"{scene.robot_path('p1')}/info"]
    assert (info["battery"], info["task"], info["colour"]) == (83, "cleanup: orange box",
                                                                "#ff8000")
    assert info["marked"] is True  # orange is also the working colour
    view.set_battery("p1", 83.2)  # the same when rounded: nothing sent
    view.offer(Snap())
    assert view.publish_once() == 0


def test_things_in_a_robot_state_colour_are_ringed() -> None:
    for world in ("simple", "boxpush", "longterm"):
        layout = scene.layout_from_world(load_world(world_path(world)))
        cmds = {c["path"]: c for c in scene.static_scene(layout) if c["type"] == "set_object"}
        for group, things in (("boxes", layout.boxes), ("objects", layout.objects)):
            for thing in things:
                path = f"{scene.ROOT}/{group}/{thing.name}"
                # drawn in its own colour, so that its colour name finds it
                assert cmds[f"{path}/shape"]["object"]["materials"][0]["color"] == thing.colour
                near = min(scene.colour_distance(thing.colour, c)
                           for c in scene.STATE_COLOURS.values())
                assert (f"{path}/ring" in cmds) == (near < scene.STATE_COLOUR_MARGIN)
    assert scene.needs_marker(0xFF8000) and not scene.needs_marker(0xFFFF00)


def test_trails_follow_robots_when_asked_for() -> None:
    layout = scene.layout_from_world(load_world(world_path("simple")))
    robot = layout.robots[0].name
    sink = RecordingSink()
    view = LiveView(layout, sink, trail_points=3, trail_step_m=0.1)
    view.publish_once()
    for k in range(6):
        view.offer({robot: (0.2 * k, 0.0, 0.0)})
        sink.commands.clear()
        view.publish_once()
    trails = [c for c in sink.commands if c["path"] == f"{scene.ROOT}/trails/{robot}"]
    (trail,) = trails
    verts = trail["object"]["geometries"][0]["data"]["attributes"]["position"]["array"]
    xs = sorted(set(round(x, 6) for x in verts[0::3]))
    assert xs == pytest.approx([0.6, 0.8, 1.0])  # a ribbon through the last three positions
    assert len(verts) == 2 * 6 * 3  # two segments of two triangles
    assert trail["object"]["materials"][0]["color"] == scene.TRAIL_COLOUR
    assert scene.TRAIL_COLOUR not in scene.STATE_COLOURS.values()
    plain = RecordingSink()
    no_trail = LiveView(layout, plain)
    for k in range(3):
        no_trail.offer({robot: (0.2 * k, 0.0, 0.0)})
        no_trail.publish_once()
    assert not [c for c in plain.commands if "/trails/" in c["path"]]


def test_laser_rays_from_a_scan() -> None:
    import math

    shape = scene.LaserShape("r", 0.1, 0.0, 0.0, -math.pi / 2, math.pi / 2, 181, 8.0)
    ranges = [2.0] * 181
    ranges[90] = float("inf")  # nothing hit straight ahead: drawn to the maximum
    ranges[0] = float("nan")  # not a reading: not drawn
    v = scene.laser_segments(shape, ranges)
    segments = [v[i:i + 6] for i in range(0, len(v), 6)]
    assert len(segments) == scene.LASER_RAYS - 1
    starts = {tuple(s[:2]) for s in segments}
    assert starts == {(0.1, 0.0)}
    ends = [(round(s[3], 6), round(s[4], 6)) for s in segments]
    assert (8.1, 0.0) in ends  # the middle ray, clipped to the laser's range
    assert ends[-1] == (0.1, 2.0)  # the leftmost ray (+90 degrees)
    turned = scene.LaserShape("r", 0.0, 0.0, math.pi / 2, 0.0, 0.0, 1, 8.0)
    (_, _, _, x1, y1, _) = scene.laser_segments(turned, [1.0])
    assert (round(x1, 6), round(y1, 6)) == (0.0, 1.0)  # a laser mounted facing left


def test_live_view_draws_scans_of_robots_with_a_laser() -> None:
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    with_laser = {shape.robot for shape in layout.lasers}
    assert with_laser and with_laser < {r.name for r in layout.robots}
    sink = RecordingSink()
    view = LiveView(layout, sink)
    view.publish_once()
    sink.commands.clear()
    robot = sorted(with_laser)[0]
    without = sorted({r.name for r in layout.robots} - with_laser)[0]
    view.offer_scans({robot: [1.0] * 181, without: [1.0] * 181})
    view.publish_once()
    lasers = [c for c in sink.commands if c["path"].endswith("/laser")]
    assert [c["path"] for c in lasers] == [f"{scene.robot_path(robot)}/laser"]
    assert lasers[0]["object"]["object"]["type"] == "LineSegments"
    assert view.publish_once() == 0  # no new scan, nothing sent
