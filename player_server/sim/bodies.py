"""Build a world's PyBullet bodies on a given client (simple collision shapes, and convex
meshes for the pieces of polygon obstacles)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import pybullet as pb

from worlds import ArenaSpec, ObstacleSpec, WorldSpec, colour_rgb01
from worlds.polygon import convex_pieces, prism_mesh

_FLOOR_THICKNESS_M = 0.05


def _rgba(colour: int, alpha: float = 1.0) -> list[float]:
    r, g, b = colour_rgb01(colour)
    return [r, g, b, alpha]


def _quat_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


@dataclass
class BodyIds:
    """PyBullet ids of a built world, by world-file name."""

    floor: int
    static: list[int]
    robots: dict[str, int]
    boxes: dict[str, int]
    objects: dict[str, int]
    markers: dict[str, int]
    chargers: dict[str, int]


def _build_arena(arena: ArenaSpec, cid: int) -> tuple[int, list[int]]:
    """The floor, the four walls and the static obstacles (in that order of creation)."""
    # Floor: a thin static box whose top is z = 0.
    fx = arena.half_x_m + 1.0
    fy = arena.half_y_m + 1.0
    floor_col = pb.createCollisionShape(
        pb.GEOM_BOX, halfExtents=[fx, fy, _FLOOR_THICKNESS_M / 2], physicsClientId=cid
    )
    floor_vis = pb.createVisualShape(
        pb.GEOM_BOX, halfExtents=[fx, fy, _FLOOR_THICKNESS_M / 2],
        rgbaColor=_rgba(arena.floor_colour), physicsClientId=cid,
    )
    floor = pb.createMultiBody(0.0, floor_col, floor_vis, [0, 0, -_FLOOR_THICKNESS_M / 2],
                               physicsClientId=cid)
    pb.changeDynamics(floor, -1, lateralFriction=1.0, physicsClientId=cid)

    static: list[int] = []
    t = arena.wall_thickness_m
    h = arena.wall_height_m
    hx, hy = arena.half_x_m, arena.half_y_m
    for cx, cy, sx, sy in (
        (hx + t / 2, 0.0, t / 2, hy + t),
        (-hx - t / 2, 0.0, t / 2, hy + t),
        (0.0, hy + t / 2, hx + t, t / 2),
        (0.0, -hy - t / 2, hx + t, t / 2),
    ):
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[sx, sy, h / 2],
                                      physicsClientId=cid)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[sx, sy, h / 2],
                                   rgbaColor=_rgba(arena.wall_colour), physicsClientId=cid)
        static.append(pb.createMultiBody(0.0, col, vis, [cx, cy, h / 2], physicsClientId=cid))

    boxes = [ob for ob in arena.obstacles if ob.shape == "box"]
    merged = len(boxes) > _MERGE_BOXES_OVER
    if merged:  # a floorplan's thousands of walls: a few compound bodies, not one body each
        static.extend(_compound_boxes(boxes, cid))
    for ob in arena.obstacles:
        if merged and ob.shape == "box":
            continue
        if ob.shape == "polygon":
            static.extend(_polygon_bodies(ob, cid))
            continue
        if ob.shape == "box":
            col = pb.createCollisionShape(
                pb.GEOM_BOX, halfExtents=[ob.size_x_m / 2, ob.size_y_m / 2, ob.height_m / 2],
                physicsClientId=cid,
            )
            vis = pb.createVisualShape(
                pb.GEOM_BOX, halfExtents=[ob.size_x_m / 2, ob.size_y_m / 2, ob.height_m / 2],
                rgbaColor=_rgba(ob.colour), physicsClientId=cid,
            )
        else:
            col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=ob.radius_m,
                                          height=ob.height_m, physicsClientId=cid)
            vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=ob.radius_m, length=ob.height_m,
                                       rgbaColor=_rgba(ob.colour), physicsClientId=cid)
        static.append(pb.createMultiBody(
            0.0, col, vis, [ob.pose.x, ob.pose.y, ob.height_m / 2], _quat_yaw(ob.pose.yaw),
            physicsClientId=cid,
        ))
    return floor, static


#: more static boxes than this are built as compound bodies (PyBullet's broad phase then
#: sees a few bodies, each with its own tree of boxes, instead of thousands)
_MERGE_BOXES_OVER = 64
#: PyBullet keeps at most 16 shapes of a collision shape array (the rest are dropped)
_BOXES_PER_COMPOUND = 16


def _compound_boxes(boxes: list[ObstacleSpec], cid: int) -> list[int]:
    """Static boxes of one colour grouped into compound bodies at the origin."""
    out: list[int] = []
    by_colour: dict[int, list[ObstacleSpec]] = {}
    for ob in boxes:
        by_colour.setdefault(ob.colour, []).append(ob)
    for colour, group in by_colour.items():
        for i in range(0, len(group), _BOXES_PER_COMPOUND):
            chunk = group[i:i + _BOXES_PER_COMPOUND]
            n = len(chunk)
            halves = [[ob.size_x_m / 2, ob.size_y_m / 2, ob.height_m / 2] for ob in chunk]
            places = [[ob.pose.x, ob.pose.y, ob.height_m / 2] for ob in chunk]
            turns = [_quat_yaw(ob.pose.yaw) for ob in chunk]
            col = pb.createCollisionShapeArray(
                [pb.GEOM_BOX] * n, halfExtents=halves, collisionFramePositions=places,
                collisionFrameOrientations=turns, physicsClientId=cid)
            vis = pb.createVisualShapeArray(
                [pb.GEOM_BOX] * n, halfExtents=halves, visualFramePositions=places,
                visualFrameOrientations=turns, physicsClientId=cid)
            body = pb.createMultiBody(0.0, col, vis, [0.0, 0.0, 0.0], physicsClientId=cid)
            pb.changeVisualShape(body, -1, rgbaColor=_rgba(colour), physicsClientId=cid)
            out.append(body)
    return out


def _polygon_bodies(ob: ObstacleSpec, cid: int) -> list[int]:
    """One static body per convex piece of a polygon obstacle: a convex mesh (PyBullet
    collides with its hull) from the piece's prism, in the obstacle's frame."""
    out: list[int] = []
    for piece in convex_pieces(ob.points):
        verts, tris = prism_mesh(piece, -ob.height_m / 2, ob.height_m / 2)
        col = pb.createCollisionShape(pb.GEOM_MESH, vertices=verts, physicsClientId=cid)
        vis = pb.createVisualShape(pb.GEOM_MESH, vertices=verts, indices=tris,
                                   rgbaColor=_rgba(ob.colour), physicsClientId=cid)
        out.append(pb.createMultiBody(
            0.0, col, vis, [ob.pose.x, ob.pose.y, ob.base_m + ob.height_m / 2],
            _quat_yaw(ob.pose.yaw), physicsClientId=cid))
    return out


def _movable(cid: int, mass_kg: float, col: int, vis: int, pos: list[float], yaw: float,
             **dynamics: Any) -> int:
    """A body the robots can push: placed at `pos` turned by `yaw`, with its own `dynamics`
    (friction, inertia), and asleep whenever it comes to rest."""
    body = pb.createMultiBody(mass_kg, col, vis, pos, _quat_yaw(yaw), physicsClientId=cid)
    pb.changeDynamics(body, -1, activationState=pb.ACTIVATION_STATE_ENABLE_SLEEPING,
                      physicsClientId=cid, **dynamics)
    return body


def build_world(spec: WorldSpec, client: int) -> BodyIds:
    """Create every body of the world on ``client``; robots' base frame is their body centre."""
    cid = client
    arena = spec.arena
    pb.setGravity(0.0, 0.0, -9.81, physicsClientId=cid)

    floor, static = _build_arena(arena, cid)

    boxes: dict[str, int] = {}
    for b in spec.boxes:
        half = [b.size_x_m / 2, b.size_y_m / 2, b.size_z_m / 2]
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=cid)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=_rgba(b.colour),
                                   physicsClientId=cid)
        boxes[b.name] = _movable(cid, b.mass_kg, col, vis, [b.pose.x, b.pose.y, half[2]],
                                 b.pose.yaw, lateralFriction=b.friction)

    objects: dict[str, int] = {}
    for o in spec.objects:
        col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=o.radius_m, height=o.height_m,
                                      physicsClientId=cid)
        vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=o.radius_m, length=o.height_m,
                                   rgbaColor=_rgba(o.colour), physicsClientId=cid)
        # Upright cylinders slide rather than topple (keeps their footprint a circle).
        inertia = o.mass_kg * 1e3
        objects[o.name] = _movable(
            cid, o.mass_kg, col, vis, [o.pose.x, o.pose.y, o.height_m / 2], o.pose.yaw,
            lateralFriction=0.5,
            localInertiaDiagonal=[inertia, inertia, 0.5 * o.mass_kg * o.radius_m ** 2])

    markers: dict[str, int] = {}
    for m in spec.markers:
        vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=m.radius_m, length=m.height_m,
                                   rgbaColor=_rgba(m.colour), physicsClientId=cid)
        markers[m.name] = pb.createMultiBody(0.0, -1, vis, [m.x, m.y, m.height_m / 2],
                                             physicsClientId=cid)

    chargers: dict[str, int] = {}
    for ch in spec.chargers:
        pad_h = 0.01
        vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=ch.radius_m, length=pad_h,
                                   rgbaColor=_rgba(ch.colour), physicsClientId=cid)
        chargers[ch.name] = pb.createMultiBody(0.0, -1, vis, [ch.x, ch.y, pad_h / 2],
                                               physicsClientId=cid)

    robots: dict[str, int] = {}
    for r in spec.robots:
        body = r.body
        half = [body.length_m / 2, body.width_m / 2, body.height_m / 2]
        if body.outline:  # the outline's prism: a convex mesh
            verts, tris = prism_mesh(body.outline, -half[2], half[2])
            col = pb.createCollisionShape(pb.GEOM_MESH, vertices=verts, physicsClientId=cid)
            vis = pb.createVisualShape(pb.GEOM_MESH, vertices=verts, indices=tris,
                                       rgbaColor=_rgba(r.colour), physicsClientId=cid)
        else:
            col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=cid)
            vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half,
                                       rgbaColor=_rgba(r.colour), physicsClientId=cid)
        c, s = math.cos(r.pose.yaw), math.sin(r.pose.yaw)
        pos = [r.pose.x + body.offset_x_m * c, r.pose.y + body.offset_x_m * s, half[2] + 0.001]
        rid = pb.createMultiBody(body.mass_kg, col, vis, pos, _quat_yaw(r.pose.yaw),
                                 physicsClientId=cid)
        # Robots do not touch the floor: the drive sets their velocity every substep, gravity
        # compensated, so they glide at a constant height (floor contacts would dominate the
        # cost of a physics step). Huge roll and pitch inertia keep them upright.
        pb.setCollisionFilterPair(rid, floor, -1, -1, 0, physicsClientId=cid)
        big = body.mass_kg * 1e3
        izz = body.mass_kg * (body.length_m ** 2 + body.width_m ** 2) / 12.0
        pb.changeDynamics(rid, -1, lateralFriction=0.3, spinningFriction=0.0,
                          rollingFriction=0.0, localInertiaDiagonal=[big, big, izz],
                          linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        robots[r.name] = rid

    return BodyIds(floor, static, robots, boxes, objects, markers, chargers)
