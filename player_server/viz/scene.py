"""The meshcat scene of a world, as plain command dictionaries.

Pure: nothing here talks to a socket or a browser. Every function returns meshcat viewer
commands (dicts with ``type`` and ``path``, ready for msgpack) that the live view sends over
its ZeroMQ channel and the offline replay embeds in an HTML file.

Scene tree (all under ``/murdoch``)::

    floor, walls/<i>, obstacles/<i>, prisms/<i>, posts/<i>,
    chargers/<name>                                           static
    boxes/<name>, objects/<name>, markers/<name>                  posed from snapshots
    robots/<name>                                             posed from snapshots
    robots/<name>/body/<state>                                one coloured body per state,
                                                              exactly one visible
    robots/<name>/nose                                        heading marker
    robots/<name>/info                                        label data (`hud`)
    robots/<name>/laser                                       laser rays (live view, option)
    boxes/<name>/ring, objects/<name>/ring                    marker (state-like colours)
    trails/<name>                                             path behind a robot (live, option)
    hud/clock, hud/legend                                     clock and legend data (`hud`)

Boxes and objects are drawn in their world colour, so that "cleanup: orange box" names what a
person sees; one whose colour could be mistaken for a robot state's (`needs_marker`) also gets
a black ring around it on the floor. Labels, the clock and the legend are HTML drawn by the
page around the view (`player_server.viz.hud`, ``overlay.js``).

Robot states and their colours are fixed here (`STATE_COLOURS`) so that the live view, the
replay and the tests agree on them.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from typing import Any

# read through this module by the live view, the replay and the tests
from player_server.viz.layout import (  # noqa: F401
    FLOOR_COLOUR,
    ROOT,
    Block,
    Disc,
    LaserShape,
    Prism,
    RobotShape,
    SceneLayout,
    layout_from_world,
    robot_path,
)
from worlds.polygon import prism_mesh

Command = dict[str, Any]


IDLE = "idle"
WORKING = "working"
CHARGING = "charging"
FAILED = "failed"
ROBOT_STATES: tuple[str, ...] = (IDLE, WORKING, CHARGING, FAILED)

STATE_COLOURS: dict[str, int] = {
    IDLE: 0x2F6FE0,  # blue
    WORKING: 0xF08C00,  # orange
    CHARGING: 0x1FB84A,  # green
    FAILED: 0x7A7A7A,  # grey
}
WALL_COLOUR = 0x4A4A52
OBSTACLE_COLOUR = 0x6B5B4B
CHARGER_COLOUR = 0xF5D000
NOSE_COLOUR = 0x111111
TRAIL_COLOUR = 0x6A3D9A  # purple: no robot state's colour
LASER_COLOUR = 0xE0245E  # crimson: no robot state's colour
LASER_RAYS = 19  # rays drawn of a scan (every k-th reading)
TRAIL_HEIGHT_M = 0.03

ROBOT_HEIGHT_M = 0.24
LABEL_HEIGHT_M = 1.6
LABEL_SCALE_M = 3.0
MARKER_COLOUR = 0x000000  # the ring around a box or object in a robot state's colour
# how far (RGB, 0-255 per channel) a box or object colour must be from every robot state
# colour not to be ringed
STATE_COLOUR_MARGIN = 110.0


def colour_rgb(colour: int) -> tuple[float, float, float]:
    r, g, b = (colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF
    return (r / 255.0, g / 255.0, b / 255.0)


def pose_matrix(x_m: float, y_m: float, z_m: float, yaw_rad: float) -> list[float]:
    """A 4x4 transform (rotation about z, then translation) in meshcat's column-major list."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return [c, s, 0.0, 0.0, -s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, x_m, y_m, z_m, 1.0]


def yaw_quaternion_xyzw(yaw_rad: float) -> list[float]:
    return [0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0)]


class IdSource:
    """Deterministic uuids so that the same scene gives the same bytes."""

    def __init__(self, prefix: str) -> None:
        self._prefix = prefix
        self._n = 0

    def next(self) -> str:
        self._n += 1
        return f"{self._prefix}-{self._n:08d}"


def _mesh(
    ids: IdSource,
    geometry: dict[str, Any],
    colour: int,
    *,
    lit: bool = True,
    opacity: float = 1.0,
    matrix: Sequence[float] | None = None,
) -> dict[str, Any]:
    gid, mid, oid = ids.next(), ids.next(), ids.next()
    material = {
        "uuid": mid,
        "type": "MeshLambertMaterial" if lit else "MeshBasicMaterial",
        "color": colour,
        "side": 2,
        "transparent": opacity < 1.0,
        "opacity": opacity,
    }
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [dict(geometry, uuid=gid)],
        "materials": [material],
        "object": {
            "uuid": oid,
            "type": "Mesh",
            "geometry": gid,
            "material": mid,
            "matrix": list(matrix) if matrix is not None else pose_matrix(0, 0, 0, 0),
        },
    }


def _box_geometry(sx: float, sy: float, sz: float) -> dict[str, Any]:
    return {"type": "BoxGeometry", "width": sx, "height": sy, "depth": sz}


def _cylinder_geometry(radius_m: float, height_m: float) -> dict[str, Any]:
    # three.js cylinders stand along y; the object matrix turns them to stand along z
    return {
        "type": "CylinderGeometry",
        "radiusTop": radius_m,
        "radiusBottom": radius_m,
        "height": height_m,
        "radialSegments": 24,
    }


def _prism_geometry(p: Prism) -> dict[str, Any]:
    """A polygon prism in world coordinates as a three.js buffer geometry."""
    return _prism_buffer(p.points, p.bottom_m, p.top_m)


def _prism_buffer(points: Sequence[tuple[float, float]], bottom: float, top: float
                  ) -> dict[str, Any]:
    verts, tris = prism_mesh(points, bottom, top)
    return {
        "type": "BufferGeometry",
        "data": {
            "attributes": {"position": {"itemSize": 3, "type": "Float32Array",
                                        "array": [c for v in verts for c in v],
                                        "normalized": False}},
            "index": {"type": "Uint32Array", "array": tris},
        },
    }


_CYLINDER_UPRIGHT = [1.0, 0, 0, 0, 0, 0, 1.0, 0, 0, -1.0, 0, 0, 0, 0, 0, 1.0]


def set_object(path: str, obj: dict[str, Any]) -> Command:
    return {"type": "set_object", "path": path, "object": obj}


def set_transform(path: str, matrix: Sequence[float]) -> Command:
    return {"type": "set_transform", "path": path, "matrix": list(matrix)}


def set_property(path: str, prop: str, value: Any) -> Command:
    return {"type": "set_property", "path": path, "property": prop, "value": value}


def delete(path: str) -> Command:
    return {"type": "delete", "path": path}


def colour_distance(a: int, b: int) -> float:
    ra, ga, ba = (a >> 16) & 0xFF, (a >> 8) & 0xFF, a & 0xFF
    rb, gb, bb = (b >> 16) & 0xFF, (b >> 8) & 0xFF, b & 0xFF
    return math.sqrt((ra - rb) ** 2 + (ga - gb) ** 2 + (ba - bb) ** 2)


def needs_marker(colour: int) -> bool:
    """Whether a box or object of this colour could be mistaken for a robot in some state
    (its colour within `STATE_COLOUR_MARGIN` of a state's): then it is ringed."""
    return min(colour_distance(colour, sc) for sc in STATE_COLOURS.values()) < (
        STATE_COLOUR_MARGIN)


def ring_triangles(radius_m: float, width_m: float, z_m: float,
                   segments: int = 32) -> list[float]:
    """A flat ring (annulus) around the origin as triangle vertices (x, y, z, ...)."""
    out: list[float] = []
    r0, r1 = radius_m, radius_m + width_m
    for k in range(segments):
        a0, a1 = math.tau * k / segments, math.tau * (k + 1) / segments
        p = [(r * math.cos(a), r * math.sin(a)) for r, a in ((r0, a0), (r1, a0), (r0, a1),
                                                               (r1, a1))]
        for vx, vy in (p[0], p[1], p[2], p[2], p[1], p[3]):
            out.extend((vx, vy, z_m))
    return out


def marker_ring(ids: IdSource, path: str, radius_m: float) -> Command:
    obj = vertices_object(ids, ring_triangles(radius_m + 0.06, 0.07, 0.012), "Mesh",
                          {"type": "MeshBasicMaterial", "color": MARKER_COLOUR, "side": 2})
    return set_object(f"{path}/ring", obj)


def label_object(ids: IdSource, text: str, *, scale_m: float = LABEL_SCALE_M,
                 height_m: float = LABEL_HEIGHT_M) -> dict[str, Any]:
    """A camera-facing sprite showing `text` (drawn by the viewer on a canvas)."""
    tid, mid, oid = ids.next(), ids.next(), ids.next()
    s = scale_m
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [],
        "textures": [
            {"uuid": tid, "type": "_text", "text": text, "font_size": 48, "font_face": "sans-serif"}
        ],
        "materials": [
            {"uuid": mid, "type": "SpriteMaterial", "map": tid, "transparent": True,
             "depthTest": False}
        ],
        "object": {
            "uuid": oid,
            "type": "Sprite",
            "material": mid,
            "matrix": [s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, 0, 0, height_m, 1],
        },
    }


def camera_commands(layout: SceneLayout) -> list[Command]:
    """Look down on the arena, slightly from the south, framing all of it."""
    cx, cy = layout.centre
    distance = max(layout.extent_m, 1.0) * 0.8
    return [
        # the orbit target is the origin of /Cameras/default: move it to the arena centre
        set_transform("/Cameras/default", pose_matrix(cx, cy, 0.0, 0.0)),
        # the camera sits in a y-up frame: (x, up, -north)
        set_property(
            "/Cameras/default/rotated/<object>", "position", [0.0, distance, distance * 0.35]
        ),
        set_property("/Grid", "visible", False),
        set_property("/Axes", "visible", False),
    ]


def static_scene(layout: SceneLayout, *, id_prefix: str = "s") -> list[Command]:
    """Commands that draw the whole scene at its initial poses, all robots idle."""
    ids = IdSource(id_prefix)
    cmds: list[Command] = [delete(ROOT)]
    cx, cy = layout.centre
    sx, sy = layout.x_max_m - layout.x_min_m, layout.y_max_m - layout.y_min_m
    cmds.append(
        set_object(
            f"{ROOT}/floor", _mesh(ids, _box_geometry(sx, sy, 0.02), layout.floor_colour, lit=False)
        )
    )
    cmds.append(set_transform(f"{ROOT}/floor", pose_matrix(cx, cy, -0.011, 0.0)))
    for group, blocks, default_colour in (
        ("walls", layout.walls, WALL_COLOUR),
        ("obstacles", layout.obstacles, OBSTACLE_COLOUR),
    ):
        for i, b in enumerate(blocks):
            path = f"{ROOT}/{group}/{i}"
            geom = _box_geometry(b.size_x_m, b.size_y_m, b.size_z_m)
            cmds.append(set_object(path, _mesh(ids, geom, b.colour or default_colour)))
            cmds.append(set_transform(path, pose_matrix(b.x_m, b.y_m, b.size_z_m / 2, b.yaw_rad)))
    for i, pr in enumerate(layout.prisms):
        path = f"{ROOT}/prisms/{i}"
        cmds.append(set_object(path, _mesh(ids, _prism_geometry(pr), pr.colour
                                           or OBSTACLE_COLOUR)))
    for i, p in enumerate(layout.posts):
        path = f"{ROOT}/posts/{i}"
        upright = list(_CYLINDER_UPRIGHT)
        upright[14] = p.height_m / 2
        geom = _cylinder_geometry(p.radius_m, p.height_m)
        cmds.append(set_object(path, _mesh(ids, geom, p.colour, matrix=upright)))
        cmds.append(set_transform(path, pose_matrix(p.x_m, p.y_m, 0.0, 0.0)))
    for c in layout.chargers:
        path = f"{ROOT}/chargers/{c.name}"
        geom = _cylinder_geometry(c.radius_m, max(c.height_m, 0.005))
        pad = _mesh(ids, geom, c.colour, lit=False, matrix=_CYLINDER_UPRIGHT)
        cmds.append(set_object(path, pad))
        cmds.append(set_transform(path, pose_matrix(c.x_m, c.y_m, 0.003, 0.0)))
    for b in layout.boxes:
        path = f"{ROOT}/boxes/{b.name}"
        # the box's own matrix lifts it so that its pose frame sits on the floor
        lift = pose_matrix(0.0, 0.0, b.size_z_m / 2, 0.0)
        geom = _box_geometry(b.size_x_m, b.size_y_m, b.size_z_m)
        cmds.append(set_object(f"{path}/shape", _mesh(ids, geom, b.colour, matrix=lift)))
        if needs_marker(b.colour):
            cmds.append(marker_ring(ids, path, math.hypot(b.size_x_m, b.size_y_m) / 2))
        cmds.append(set_transform(path, pose_matrix(b.x_m, b.y_m, 0.0, b.yaw_rad)))
    for group, discs in (("objects", layout.objects), ("markers", layout.markers)):
        for o in discs:
            cmds.extend(_upright_disc(ids, f"{ROOT}/{group}/{o.name}", o))
    for r in layout.robots:
        cmds.extend(robot_commands(ids, r))
    cmds.extend(camera_commands(layout))
    return cmds


def _upright_disc(ids: IdSource, path: str, o: Disc) -> list[Command]:
    lift = list(_CYLINDER_UPRIGHT)
    lift[14] = o.height_m / 2
    geom = _cylinder_geometry(o.radius_m, o.height_m)
    cmds = [set_object(f"{path}/shape", _mesh(ids, geom, o.colour, matrix=lift))]
    if needs_marker(o.colour):
        cmds.append(marker_ring(ids, path, o.radius_m))
    cmds.append(set_transform(path, pose_matrix(o.x_m, o.y_m, 0.0, 0.0)))
    return cmds


def robot_commands(ids: IdSource, r: RobotShape) -> list[Command]:
    path = robot_path(r.name)
    lift = pose_matrix(r.offset_x_m, 0.0, ROBOT_HEIGHT_M / 2, 0.0)
    geom = _box_geometry(r.length_m, r.width_m, ROBOT_HEIGHT_M)
    if r.outline:  # the outline's prism, about the body centre
        lift = pose_matrix(r.offset_x_m, 0.0, 0.0, 0.0)
        geom = _prism_buffer(r.outline, 0.0, ROBOT_HEIGHT_M)
    cmds: list[Command] = []
    for state in ROBOT_STATES:
        body = f"{path}/body/{state}"
        cmds.append(set_object(body, _mesh(ids, geom, STATE_COLOURS[state], matrix=lift)))
        cmds.append(set_property(body, "visible", state == IDLE))
    nose = pose_matrix(r.offset_x_m + r.length_m * 0.3, 0.0, ROBOT_HEIGHT_M + 0.01, 0.0)
    nose_geom = _box_geometry(r.length_m * 0.3, r.width_m * 0.25, 0.02)
    cmds.append(set_object(f"{path}/nose", _mesh(ids, nose_geom, NOSE_COLOUR, matrix=nose)))
    cmds.append(set_transform(path, pose_matrix(r.x_m, r.y_m, 0.0, r.yaw_rad)))
    return cmds


def state_change(robot: str, old: str | None, new: str) -> list[Command]:
    """Show the body of `new` and hide the others (all of them when `old` is unknown)."""
    if new not in STATE_COLOURS:
        raise ValueError(f"unknown robot state {new!r}; expected one of {ROBOT_STATES}")
    states: Iterable[str] = ROBOT_STATES if old is None else (old,)
    cmds = [
        set_property(f"{robot_path(robot)}/body/{s}", "visible", False) for s in states if s != new
    ]
    cmds.append(set_property(f"{robot_path(robot)}/body/{new}", "visible", True))
    return cmds


TRAIL_WIDTH_M = 0.07


def trail_triangles(points: Sequence[tuple[float, float]],
                    width_m: float = TRAIL_WIDTH_M) -> list[float]:
    """A flat ribbon through `points` as triangle vertices (x, y, z, ...): two per segment
    (WebGL draws lines one pixel wide whatever their width, too thin to see)."""
    out: list[float] = []
    h = width_m / 2.0
    z = TRAIL_HEIGHT_M
    for (x0, y0), (x1, y1) in itertools.pairwise(points):
        dx, dy = x1 - x0, y1 - y0
        length = math.hypot(dx, dy)
        if length == 0.0:
            continue
        nx, ny = -dy / length * h, dx / length * h
        a, b = (x0 + nx, y0 + ny), (x0 - nx, y0 - ny)
        c, d = (x1 + nx, y1 + ny), (x1 - nx, y1 - ny)
        for vx, vy in (a, b, c, c, b, d):
            out.extend((float(vx), float(vy), z))
    return out


def vertices_object(ids: IdSource, vertices: list[float], object_type: str,
                    material: dict[str, Any]) -> dict[str, Any]:
    """A three.js object drawn from flat (x, y, z, ...) vertices in its parent's frame: a
    "Mesh" of triangles or "LineSegments" of point pairs, with `material` (its type, colour
    and options)."""
    gid, mid, oid = ids.next(), ids.next(), ids.next()
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [{
            "uuid": gid, "type": "BufferGeometry",
            "data": {"attributes": {"position": {
                "itemSize": 3, "type": "Float32Array", "array": vertices,
                "normalized": False,
            }}},
        }],
        "materials": [{"uuid": mid, **material}],
        "object": {"uuid": oid, "type": object_type, "geometry": gid, "material": mid,
                   "matrix": pose_matrix(0.0, 0.0, 0.0, 0.0)},
    }


def trail_command(ids: IdSource, robot: str, points: Sequence[tuple[float, float]]) -> Command:
    """A ribbon through `points` (x, y) just above the floor: where the robot has been."""
    obj = vertices_object(ids, trail_triangles(points), "Mesh",
                          {"type": "MeshBasicMaterial", "color": TRAIL_COLOUR, "side": 2})
    return set_object(f"{ROOT}/trails/{robot}", obj)


def laser_segments(shape: LaserShape, ranges: Sequence[float],
                   rays: int = LASER_RAYS) -> list[float]:
    """Line-segment vertices (robot frame, x y z pairs) for `rays` evenly chosen readings of
    one scan; a reading at or beyond the maximum range (nothing hit) is drawn to the maximum."""
    n = len(ranges)
    if n == 0:
        return []
    count = min(rays, n)
    step = (shape.max_angle_rad - shape.min_angle_rad) / (n - 1) if n > 1 else 0.0
    c, s = math.cos(shape.yaw_rad), math.sin(shape.yaw_rad)
    z = ROBOT_HEIGHT_M + 0.02
    out: list[float] = []
    for k in range(count):
        i = round(k * (n - 1) / (count - 1)) if count > 1 else 0
        r = float(ranges[i])
        if math.isnan(r) or r <= 0.0:
            continue
        r = min(r, shape.max_range_m)
        a = shape.min_angle_rad + i * step
        lx, ly = r * math.cos(a), r * math.sin(a)
        out.extend((shape.x_m, shape.y_m, z,
                    shape.x_m + c * lx - s * ly, shape.y_m + s * lx + c * ly, z))
    return out


def laser_command(ids: IdSource, shape: LaserShape, ranges: Sequence[float]) -> Command:
    obj = vertices_object(ids, laser_segments(shape, ranges), "LineSegments",
                          {"type": "LineBasicMaterial", "color": LASER_COLOUR,
                           "transparent": True, "opacity": 0.8})
    return set_object(f"{robot_path(shape.robot)}/laser", obj)
