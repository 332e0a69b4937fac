"""Constant arrays derived once from a world spec for vectorised sensing (pure numpy).

Index conventions: footprint rectangles are the static box obstacles, then the robots' bodies,
then the boxes; footprint polygons (after the rectangles) are the convex pieces of the static
polygon obstacles in world-file order, then the bodies of the robots with an outline (whose
rectangles are then never hit: their top is -inf); footprint circles are the static
cylinders, then the objects; blob targets are robots, boxes, objects, markers, chargers in
world-file order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from player_server.sim.blobs import Cameras
from player_server.sim.footprint_cast import Polygons, Room
from worlds import ObstacleSpec, RobotSpec, WorldSpec
from worlds.polygon import convex_pieces

F64 = NDArray[np.float64]


def _arr(values: list[float]) -> F64:
    return np.array(values, dtype=np.float64)


@dataclass(frozen=True)
class WorldArrays:
    n_robots: int
    n_boxes: int
    n_objects: int
    room: Room
    n_static_rects: int
    static_rect_centre: NDArray[np.complex128]
    static_rect_head: NDArray[np.complex128]
    static_circle_centre: NDArray[np.complex128]
    fp_half: NDArray[np.complex128]  # every footprint rectangle: hx + i hy
    fp_rect_radius: F64
    fp_rect_top: F64
    fp_circle_radius: F64  # static cylinders then objects
    fp_circle_top: F64
    static_polygons: Polygons  # the polygon obstacles' convex pieces
    outline_robot: NDArray[np.int64]  # the robots whose body is an outline polygon
    outline_start: NDArray[np.int64]  # their vertices' offsets into outline_local
    outline_local: NDArray[np.complex128]  # about the body centre, in the body frame
    outline_radius: F64
    outline_top: F64
    own_footprint: NDArray[np.int64]  # per robot: the footprint of its body
    rect_half_x: F64  # robots then boxes
    body_offset: F64  # robots: body centre ahead of the axle centre
    rect_half_y: F64
    rect_top: F64
    obj_radius: F64
    obj_top: F64
    t_radius: F64
    t_half_x: F64
    t_half_y: F64
    t_z_bottom: F64
    t_z_top: F64
    t_colour: NDArray[np.int64]
    t_colour_index: NDArray[np.int64]  # each target's colour in the world's palette
    charger_xy: F64
    channel: NDArray[np.int64]  # (n_robots, palette colours): first blobfinder channel or -1
    cam: F64  # (n_robots, 10): mount x, y, z, yaw, tilt, fov, width, height, range, min_area
    channels: tuple[tuple[int, ...], ...]

    @staticmethod
    def from_spec(spec: WorldSpec) -> WorldArrays:
        a = spec.arena
        boxes_static = [o for o in a.obstacles if o.shape == "box"]
        cyl_static = [o for o in a.obstacles if o.shape == "cylinder"]
        robots, boxes, objects = spec.robots, spec.boxes, spec.objects
        n_t = len(robots) + len(boxes) + len(objects) + len(spec.markers) + len(spec.chargers)
        zeros = [0.0] * n_t
        radius = (
            [0.0] * (len(robots) + len(boxes)) + [o.radius_m for o in objects]
            + [m.radius_m for m in spec.markers] + [c.radius_m for c in spec.chargers]
        )
        half_x = ([r.body.length_m / 2 for r in robots] + [b.size_x_m / 2 for b in boxes]
                  + [0.0] * (n_t - len(robots) - len(boxes)))
        half_y = ([r.body.width_m / 2 for r in robots] + [b.size_y_m / 2 for b in boxes]
                  + [0.0] * (n_t - len(robots) - len(boxes)))
        z_top = ([r.body.height_m for r in robots] + [b.size_z_m for b in boxes]
                 + [o.height_m for o in objects] + [m.height_m for m in spec.markers]
                 + [0.01 for _ in spec.chargers])
        colour = ([r.colour for r in robots] + [b.colour for b in boxes]
                  + [o.colour for o in objects] + [m.colour for m in spec.markers]
                  + [c.colour for c in spec.chargers])
        palette = sorted(set(colour))
        colour_index = {c: j for j, c in enumerate(palette)}
        channel = np.full((len(robots), len(palette)), -1, dtype=np.int64)
        cam = np.zeros((len(robots), 10))
        channels: list[tuple[int, ...]] = []
        for i, r in enumerate(robots):
            bf, c = r.devices.blobfinder, r.devices.camera
            channels.append(bf.channels if bf is not None else ())
            if bf is not None:
                for ch, col in reversed(list(enumerate(bf.channels))):  # the first one wins
                    if col in colour_index:
                        channel[i, colour_index[col]] = ch
            if c is not None:
                cam[i] = (c.pose.x, c.pose.y, c.pose.z, c.pose.yaw, c.tilt_rad, c.fov_h_rad,
                          c.width_px, c.height_px, c.max_range_m,
                          bf.min_area_px if bf is not None else 1)
        static_polygons = polygon_footprints(a.obstacles)
        fp_hx = _arr([o.size_x_m / 2 for o in boxes_static] + half_x[:len(robots) + len(boxes)])
        fp_hy = _arr([o.size_y_m / 2 for o in boxes_static] + half_y[:len(robots) + len(boxes)])
        return WorldArrays(
            n_robots=len(robots),
            n_boxes=len(boxes),
            n_objects=len(objects),
            room=Room(a.half_x_m, a.half_y_m, a.wall_height_m),
            n_static_rects=len(boxes_static),
            static_rect_centre=np.array([complex(o.pose.x, o.pose.y) for o in boxes_static],
                                        dtype=np.complex128),
            static_rect_head=np.exp(1j * _arr([o.pose.yaw for o in boxes_static])),
            static_circle_centre=np.array([complex(o.pose.x, o.pose.y) for o in cyl_static],
                                          dtype=np.complex128),
            fp_half=fp_hx + 1j * fp_hy,
            fp_rect_radius=np.hypot(fp_hx, fp_hy),
            fp_rect_top=_arr([o.height_m for o in boxes_static]
                             + [-np.inf if r.body.outline else r.body.height_m for r in robots]
                             + [b.size_z_m for b in boxes]),
            fp_circle_radius=_arr([o.radius_m for o in cyl_static]
                                  + [o.radius_m for o in objects]),
            fp_circle_top=_arr([o.height_m for o in cyl_static] + [o.height_m for o in objects]),
            static_polygons=static_polygons,
            **_outlines(robots, len(boxes_static), len(fp_hx), static_polygons.count),
            body_offset=_arr([r.body.offset_x_m for r in robots]),
            rect_half_x=_arr([r.body.length_m / 2 for r in robots]
                             + [b.size_x_m / 2 for b in boxes]),
            rect_half_y=_arr([r.body.width_m / 2 for r in robots]
                             + [b.size_y_m / 2 for b in boxes]),
            rect_top=_arr([r.body.height_m for r in robots] + [b.size_z_m for b in boxes]),
            obj_radius=_arr([o.radius_m for o in objects]),
            obj_top=_arr([o.height_m for o in objects]),
            t_radius=_arr(radius),
            t_half_x=_arr(half_x),
            t_half_y=_arr(half_y),
            t_z_bottom=_arr(zeros),
            t_z_top=_arr(z_top),
            t_colour=np.array(colour, dtype=np.int64),
            t_colour_index=np.array([colour_index[c] for c in colour], dtype=np.int64),
            charger_xy=np.array([[c.x, c.y] for c in spec.chargers],
                                dtype=np.float64).reshape(-1, 2),
            channel=channel,
            cam=cam,
            channels=tuple(channels),
        )

    @property
    def n_fp_rects(self) -> int:
        """Footprint rectangles: static boxes, robots' bodies and boxes."""
        return int(self.fp_half.size)

    def own_body(self, robot: NDArray[np.int64], local: NDArray[np.complex128]
                 ) -> NDArray[np.int64]:
        """Footprint index of the body of each robot when the robot-frame point ``local``
        (axle frame) lies strictly inside it, else -1: a ray from there cannot see it."""
        p = local - self.body_offset[robot]
        inside = (np.abs(p.real) < self.rect_half_x[robot]) & \
            (np.abs(p.imag) < self.rect_half_y[robot])
        return np.where(inside, self.own_footprint[robot], -1).astype(np.int64)

    def polygons(self, body: NDArray[np.complex128], head: NDArray[np.complex128]) -> Polygons:
        """This tick's footprint polygons: the static ones, then the outlines of the robots
        with one, placed by every robot's body centre and heading exp(i yaw)."""
        r = self.outline_robot
        if r.size == 0:
            return self.static_polygons
        st = self.static_polygons
        at = np.repeat(r, np.diff(self.outline_start))
        return Polygons(
            start=np.concatenate([st.start, st.start[-1] + self.outline_start[1:]]),
            vert=np.concatenate([st.vert, body[at] + head[at] * self.outline_local]),
            centre=np.concatenate([st.centre, body[r]]),
            radius=np.concatenate([st.radius, self.outline_radius]),
            bottom=np.concatenate([st.bottom, np.zeros(r.size)]),
            top=np.concatenate([st.top, self.outline_top]))

    def cameras(self, idx: NDArray[np.int64], rx: F64, ry: F64, ryaw: F64,
                pan: F64, tilt: F64, zoom: F64) -> Cameras:
        """World poses of the cameras of robots ``idx`` (robot poses and PTZ per robot)."""
        m = self.cam[idx]
        c, s = np.cos(ryaw), np.sin(ryaw)
        return Cameras(
            x=rx + c * m[:, 0] - s * m[:, 1],
            y=ry + s * m[:, 0] + c * m[:, 1],
            z=m[:, 2],
            yaw=ryaw + m[:, 3] + pan,
            tilt=m[:, 4] + tilt,
            fov_h=np.where(zoom > 0, zoom, m[:, 5]),
            width=m[:, 6],
            height=m[:, 7],
            max_range=m[:, 8],
            min_area=m[:, 9],
        )


def polygon_footprints(obstacles: tuple[ObstacleSpec, ...]) -> Polygons:
    """The convex pieces of the polygon obstacles, placed in the world."""
    pieces = []
    for o in obstacles:
        if o.shape == "polygon":
            for piece in convex_pieces(o.points):
                pieces.append(([complex(x, y) for x, y in o.placed(piece)], o.base_m, o.top_m))
    return Polygons.build(pieces)


def _outlines(robots: tuple[RobotSpec, ...], n_static_rects: int, n_rects: int,
              n_static_polygons: int) -> dict[str, np.ndarray]:
    """The outline polygons of the robots with one, and the footprint of every robot's body
    (its rectangle, or its polygon after the static ones)."""
    which = [i for i, r in enumerate(robots) if r.body.outline]
    local = [np.array([complex(x, y) for x, y in robots[i].body.outline]) for i in which]
    start = np.zeros(len(which) + 1, dtype=np.int64)
    start[1:] = np.cumsum([v.size for v in local], dtype=np.int64)
    own = np.arange(len(robots), dtype=np.int64) + n_static_rects
    for k, i in enumerate(which):
        own[i] = n_rects + n_static_polygons + k
    return {
        "outline_robot": np.array(which, dtype=np.int64),
        "outline_start": start,
        "outline_local": (np.concatenate(local) if local
                          else np.zeros(0, dtype=np.complex128)),
        "outline_radius": _arr([float(np.abs(v).max()) for v in local]),
        "outline_top": _arr([robots[i].body.height_m for i in which]),
        "own_footprint": own,
    }
