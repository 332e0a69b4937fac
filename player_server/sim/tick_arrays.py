"""The world's per-tick arrays: poses of the moving bodies, the robots' frame, footprints.

Read from PyBullet and the robots' state once per tick, on first use, and cached by the world
until the next tick; the sensing pass and the device models read them from here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np
import pybullet as pb
from numpy.typing import NDArray

from player_server.sim import grid_index
from player_server.sim.drive import yaw_of as _yaw_of
from player_server.sim.fastsense import Frame
from player_server.sim.footprint_cast import Footprints

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState
    from player_server.sim.world_arrays import WorldArrays


class TickWorld(Protocol):
    """What the per-tick arrays are read from (the Simulation implements it)."""

    physics_client: int
    robots: list[RobotState]
    arrays: WorldArrays
    robot_offset: NDArray[np.float64]
    dyn_ids: list[int]
    """PyBullet ids of the boxes, then the objects (the rows of `dynamic`)."""
    dyn_row: dict[str, int]
    obj_visible: NDArray[np.bool_]
    fp_radius: NDArray[np.float64]
    fp_top: NDArray[np.float64]
    fixed_target_pos: NDArray[np.complex128]
    fixed_target_head: NDArray[np.complex128]

    def cached(self, key: object, compute: Callable[[], object]) -> object: ...


class TickArrays:
    def __init__(self, world: TickWorld) -> None:
        self.world = world

    def dynamic_poses(self) -> NDArray[np.float64]:
        """(n_boxes + n_objects, 3) poses, boxes first."""
        return self.dynamic()[0]

    def dynamic(self) -> tuple[NDArray[np.float64], NDArray[np.complex128],
                                NDArray[np.complex128]]:
        """Boxes' and objects' poses (n, 3), positions x + iy and headings exp(i yaw), read
        from PyBullet in one pass per tick."""
        w = self.world

        def compute() -> tuple[NDArray[np.float64], NDArray[np.complex128],
                               NDArray[np.complex128]]:
            cid = w.physics_client
            get = pb.getBasePositionAndOrientation
            rows, pos, head = [], [], []
            for bid in w.dyn_ids:
                p, q = get(bid, physicsClientId=cid)
                yaw = _yaw_of(q)
                rows.append((p[0], p[1], yaw))
                pos.append(complex(p[0], p[1]))
                head.append(complex(math.cos(yaw), math.sin(yaw)))
            return (np.array(rows, dtype=np.float64).reshape(-1, 3),
                    np.array(pos, dtype=np.complex128), np.array(head, dtype=np.complex128))

        return w.cached("dynamic", compute)  # type: ignore[return-value]

    def dyn_pose(self, name: str) -> tuple[float, float, float]:
        w = self.world
        x, y, yaw = self.dynamic_poses()[w.dyn_row[name]].tolist()
        return (x, y, yaw)

    def footprints(self) -> Footprints:
        """This tick's footprints: static obstacles, robots' bodies and boxes (rectangles),
        the static polygon obstacles' convex pieces and the robots' outlines (polygons),
        static cylinders and the objects not held or stored (circles)."""
        w = self.world

        def compute() -> Footprints:
            wa = w.arrays
            frame = self.frame()
            _, pos, head = self.dynamic()
            nb = wa.n_boxes
            vis = w.obj_visible
            if vis.all():
                circles, c_radius, c_top = pos[nb:], w.fp_radius, w.fp_top
            else:
                keep = np.concatenate([np.ones(wa.n_fp_rects + wa.static_circle_centre.size,
                                               dtype=bool), vis])
                circles = pos[nb:][vis]
                c_radius, c_top = w.fp_radius[keep], w.fp_top[keep]
            return Footprints(
                centre=np.concatenate([wa.static_rect_centre, frame.body, pos[:nb],
                                       wa.static_circle_centre, circles]),
                head_conj=np.concatenate([wa.static_rect_head, frame.head,
                                          head[:nb]]).conjugate(),
                half=wa.fp_half,
                radius=c_radius,
                top=c_top,
            ).with_polygons(wa.polygons(frame.body, frame.head))

        return w.cached("footprints", compute)  # type: ignore[return-value]

    def frame(self) -> Frame:
        w = self.world
        def compute() -> Frame:
            robots = w.robots
            n = len(robots)
            x = np.array([st.x for st in robots], dtype=np.float64)
            y = np.array([st.y for st in robots], dtype=np.float64)
            yaw_list = [st.yaw for st in robots]
            cos, sin = math.cos, math.sin
            c = np.array([cos(a) for a in yaw_list], dtype=np.float64)
            s = np.array([sin(a) for a in yaw_list], dtype=np.float64)
            pos = np.empty(n, dtype=np.complex128)
            pos.real, pos.imag = x, y
            head = np.empty(n, dtype=np.complex128)
            head.real, head.imag = c, s
            # the body centre, the axle centre plus the heading times the offset
            off = w.robot_offset
            body = np.empty(n, dtype=np.complex128)
            body.real, body.imag = x + c * off, y + s * off
            return Frame(pos, head, np.array(yaw_list, dtype=np.float64), body)

        return w.cached("frame", compute)  # type: ignore[return-value]

    def robots_near(self, x: float, y: float, reach: float) -> list[int]:
        """Indices (increasing) of the robots whose axle centre may lie within ``reach`` of
        (x, y) on each axis: a superset, from this tick's grid of the robots."""
        w = self.world
        if len(w.robots) < grid_index.FEW:
            return list(range(len(w.robots)))

        def compute() -> grid_index.Grid:
            pos = self.frame().pos
            return grid_index.build(pos.real.copy(), pos.imag.copy(), np.zeros(pos.size),
                                    _room_bounds(w))

        grid = w.cached("robot_grid", compute)
        assert isinstance(grid, grid_index.Grid)
        return grid.near(x, y, reach).tolist()

    def objects_near(self, x: float, y: float, reach: float) -> list[int]:
        """Rows (increasing, in world-file order) of the objects whose centre may lie within
        ``reach`` of (x, y) on each axis: a superset, from this tick's grid of the objects."""
        w = self.world
        if w.arrays.n_objects < grid_index.FEW:
            return list(range(w.arrays.n_objects))

        def compute() -> grid_index.Grid:
            pos = self.dynamic()[1][w.arrays.n_boxes:]
            return grid_index.build(pos.real.copy(), pos.imag.copy(), np.zeros(pos.size),
                                    _room_bounds(w))

        grid = w.cached("object_grid", compute)
        assert isinstance(grid, grid_index.Grid)
        return grid.near(x, y, reach).tolist()

    def target_poses(self, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        w = self.world
        _, pos, head = self.dynamic()
        t_pos = np.concatenate([frame.body, pos, w.fixed_target_pos])
        t_head = np.concatenate([frame.head, head, w.fixed_target_head])
        return t_pos, t_head


def _room_bounds(w: TickWorld) -> tuple[float, float, float, float]:
    room = w.arrays.room
    return (-room.half_x, -room.half_y, room.half_x, room.half_y)
