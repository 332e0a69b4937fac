"""Grippers: paddles that open and close in their move time, grab the nearest grippable
object between them, and store and retrieve objects."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import pybullet as pb

from player_server.sim.devices.state import Paddles
from player_server.sim.readings import GripperState, fast_constructor

_make_gripper_state = fast_constructor(GripperState)

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState
    from player_server.sim.devices.world import DeviceWorld

GRIPPER_COMMANDS = ("open", "close", "stop", "store", "retrieve")


class GripperModel:
    kinds: ClassVar[tuple[str, ...]] = ("gripper",)
    order: ClassVar[int] = 30
    ticking: ClassVar[bool] = True

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world

    def build(self) -> None:
        self._max_radius = max((o.radius_m for o in self.world.spec.objects), default=0.0)
        self._radius = np.array([o.radius_m for o in self.world.spec.objects], dtype=np.float64)
        for st in self.world.robots:
            if st.spec.devices.gripper is not None:
                st.gripper = Paddles()

    def advance(self, dt: float) -> None:
        for st in self.world.robots:
            if st.gripper is not None:
                self._advance_gripper(st, dt)

    def _grip_zone(self, st: RobotState) -> str | None:
        """The nearest grippable object between the paddles, if any (the first in world-file
        order among equally near ones). The candidates near the robot are tested together."""
        w = self.world
        g = st.spec.devices.gripper
        assert g is not None
        reach = abs(g.pose.x) + g.depth_m / 2 + g.width_m / 2 + self._max_radius + 1e-6
        rows = w.tick_arrays.objects_near(st.x, st.y, reach)
        if not rows:
            return None
        idx = np.asarray(rows, dtype=np.int64)
        pose = w.tick_arrays.dynamic_poses()[w.arrays.n_boxes:][idx]
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        wx, wy = pose[:, 0] - st.x, pose[:, 1] - st.y
        lx, ly = c * wx + s * wy, -s * wx + c * wy
        radius = self._radius[idx]
        d = np.abs(lx - g.pose.x)
        inside = ((np.abs(ly) <= g.width_m / 2) & (d <= g.depth_m / 2 + radius)
                  & (radius <= g.max_object_radius_m))
        best, best_d = None, math.inf
        specs = w.spec.objects
        for j in np.flatnonzero(inside).tolist():
            name = specs[rows[j]].name
            if name in w.hidden or name in w.held:
                continue
            dj = float(d[j])
            if dj < best_d:
                best, best_d = name, dj
        return best

    def gripper(self, robot: str) -> GripperState:
        st = self.world.device(robot, "gripper")

        def compute() -> GripperState:
            g = st.gripper
            spec = st.spec.devices.gripper
            assert g is not None and spec is not None
            beams = 0
            if g.holding is not None:
                beams = 3
            elif self._grip_zone(st) is not None:
                beams = 1
            return _make_gripper_state(g.state, beams, g.holding, len(g.stored), spec.capacity)

        return self.world.cached(("gripper", st.index), compute)  # type: ignore[return-value]

    def gripper_command(self, robot: str, command: str) -> None:
        w = self.world
        st = w.device(robot, "gripper")
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        if command not in GRIPPER_COMMANDS:
            raise ValueError(f"gripper command must be one of {GRIPPER_COMMANDS}, not "
                             f"{command!r}")
        if command == "open":
            if g.state == "open":
                return
            self._release(st)
            self._start_paddles(st, "open")
        elif command == "close":
            if g.state == "closed" or (g.state == "moving" and g.target == "closed"):
                return
            self._start_paddles(st, "closed")
        elif command == "stop":
            # Paddles halted part-way are reported open (they hold nothing).
            if g.state == "moving":
                g.state = g.target = "open"
                g.remaining_s = 0.0
        elif command == "store":
            if g.holding is not None and len(g.stored) < spec.capacity:
                name = g.holding
                self._release(st)
                w.hide_object(name)
                g.stored.append(name)
        elif command == "retrieve" and g.stored and g.holding is None:
            name = g.stored.pop()
            w.unhide_object(name)
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            ospec = w.object_spec(name)
            bid = w.ids.objects[name]
            pb.resetBasePositionAndOrientation(
                bid, (st.x + c * spec.pose.x, st.y + s * spec.pose.x, ospec.height_m / 2),
                (0, 0, 0, 1), physicsClientId=w.physics_client)
            pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=w.physics_client)
            self._grab(st, name)
            g.state = "closed"
            g.target = "closed"
        w.invalidate()

    def _start_paddles(self, st: RobotState, target: str) -> None:
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        g.target = target
        g.state = "moving"
        g.remaining_s = spec.move_time_s
        if spec.move_time_s <= 0:
            self._finish_gripper(st)

    def _advance_gripper(self, st: RobotState, dt: float) -> None:
        g = st.gripper
        assert g is not None
        if g.state == "moving" and g.target in ("open", "closed"):
            g.remaining_s -= dt
            if g.remaining_s <= 1e-9:
                self._finish_gripper(st)

    def _finish_gripper(self, st: RobotState) -> None:
        g = st.gripper
        assert g is not None
        g.state = g.target
        g.remaining_s = 0.0
        if g.state == "closed" and g.holding is None:
            name = self._grip_zone(st)
            if name is not None:
                self._grab(st, name)

    def _grab(self, st: RobotState, name: str) -> None:
        w = self.world
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        cid = w.physics_client
        bid = w.ids.objects[name]
        ospec = w.object_spec(name)
        body = st.spec.body
        # Hold the object centred between the paddles, slightly lifted.
        parent = (spec.pose.x - body.offset_x_m, 0.0,
                  ospec.height_m / 2 + 0.01 - body.height_m / 2)
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        pb.resetBasePositionAndOrientation(
            bid, (st.x + c * spec.pose.x, st.y + s * spec.pose.x, ospec.height_m / 2 + 0.01),
            (0, 0, 0, 1), physicsClientId=cid)
        pb.setCollisionFilterPair(st.body, bid, -1, -1, 0, physicsClientId=cid)
        g.constraint = pb.createConstraint(
            st.body, -1, bid, -1, pb.JOINT_FIXED, (0, 0, 0), parent, (0, 0, 0),
            physicsClientId=cid)
        pb.changeConstraint(g.constraint, maxForce=500.0, physicsClientId=cid)
        g.holding = name
        w.held.add(name)
        w.update_visibility()
        w.invalidate()

    def _release(self, st: RobotState) -> None:
        w = self.world
        g = st.gripper
        assert g is not None
        if g.holding is None:
            return
        cid = w.physics_client
        if g.constraint >= 0:
            pb.removeConstraint(g.constraint, physicsClientId=cid)
        bid = w.ids.objects[g.holding]
        pb.setCollisionFilterPair(st.body, bid, -1, -1, 1, physicsClientId=cid)
        w.held.discard(g.holding)
        w.update_visibility()
        g.holding = None
        g.constraint = -1
        w.invalidate()

    def release_if_held(self, name: str) -> None:
        """The object `name` was moved by hand: whoever held it lets go (paddles open)."""
        for st in self.world.robots:
            if st.gripper is not None and st.gripper.holding == name:
                self._release(st)
                st.gripper.state = "open"
                st.gripper.target = "open"
