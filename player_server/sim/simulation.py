"""The Simulation: one PyBullet DIRECT client, stepped in integer ticks of interval_sim.

The world: bodies, the clock and stepping. Each tick sets every robot's drive velocity
(acceleration-limited) and runs ``physics_substeps`` physics steps, then reads the robots'
poses to advance odometry and stall flags, and lets each device model advance (batteries,
grippers, PTZ heads). The devices are models of their own (`player_server.sim.devices`, one
module per kind, with a registry); the Simulation builds them with the world, advances them
and answers the device calls (the drivers' `SimPort`) through them. Readings are computed
lazily on request and cached until the next tick; the range sensors and blobfinders read
before are sensed together (`player_server.sim.sensing`).
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable
from typing import TypeVar, cast

import numpy as np
import pybullet as pb
from numpy.typing import NDArray

from player_server.sim.bodies import BodyIds, build_world
from player_server.sim.devices import MODEL_CLASSES, DeviceModel
from player_server.sim.devices.bumper import BumperModel
from player_server.sim.devices.camera import CameraModel
from player_server.sim.devices.gripper import GripperModel
from player_server.sim.devices.position2d import Position2dModel
from player_server.sim.devices.power import PowerModel
from player_server.sim.devices.ptz import PtzModel
from player_server.sim.devices.ranging import RangeModel
from player_server.sim.devices.state import RobotState
from player_server.sim.devices.tracking import TrackingModel
from player_server.sim.devices.world import Sensed
from player_server.sim.drive import ramp, wrap_angle
from player_server.sim.drive import yaw_of as _yaw_of
from player_server.sim.looks import Looks
from player_server.sim.readings import (
    Blob,
    BodyPose,
    Fiducial,
    GripperState,
    Odometry,
    PowerState,
    PtzState,
    SceneSnapshot,
    TrackedObject,
    fast_constructor,
)
from player_server.sim.sensing import SensingPass
from player_server.sim.tick_arrays import TickArrays
from player_server.sim.timings import Timings
from player_server.sim.world_arrays import WorldArrays
from worlds import ObjectSpec, WorldSpec

log = logging.getLogger(__name__)

_make_pose = fast_constructor(BodyPose)
M = TypeVar("M")

_HIDDEN_Z_M = -50.0
_GRAVITY_MPS2 = 9.81


def _quat_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


class Simulation:
    """A simulated world. Not thread-safe: one owner calls it (the server's sim thread)."""

    def __init__(
        self,
        spec: WorldSpec,
        seed: int | None = None,
        fidelity: str | None = None,
        *,
        profile_clock: Callable[[], float] | None = None,
    ) -> None:
        self.spec = spec
        self.fidelity = fidelity or spec.sim.fidelity
        if self.fidelity not in ("fast", "render"):
            raise ValueError(f"fidelity must be 'fast' or 'render', not {self.fidelity!r}")
        self.seed = spec.sim.seed if seed is None else seed
        self.interval_s = spec.sim.interval_sim_s
        self.substeps = spec.sim.physics_substeps
        self._clock = profile_clock
        self.timings = Timings()
        self.physics_client = pb.connect(pb.DIRECT)
        self._closed = False
        self._robot_index = {r.name: i for i, r in enumerate(spec.robots)}
        # the device models (the registry's, in its order) and the sensing pass
        self.models: tuple[DeviceModel, ...] = tuple(cls(self) for cls in MODEL_CLASSES)
        self.drive_model = self.model(Position2dModel)
        self.power_model = self.model(PowerModel)
        self.gripper_model = self.model(GripperModel)
        self.ptz_model = self.model(PtzModel)
        self.bumper_model = self.model(BumperModel)
        self.range_model = self.model(RangeModel)
        self.camera_model = self.model(CameraModel)
        self.tracking_model = self.model(TrackingModel)
        # the models with per-tick state (after power, which the timings count apart)
        self._advanced_after_power = tuple(m for m in self.models
                                           if m.ticking and m is not self.power_model)
        self.tick_arrays = TickArrays(self)
        self.sensing = SensingPass(self, self.range_model, self.camera_model,
                                   self.tick_arrays, profile_clock, self.timings)
        self._build()

    def model(self, cls: type[M]) -> M:
        """This world's model of the class `cls` (one of `devices.MODEL_CLASSES`)."""
        return cast(M, next(m for m in self.models if type(m) is cls))

    # ---- lifecycle -------------------------------------------------------------------------
    def _build(self) -> None:
        cid = self.physics_client
        pb.resetSimulation(physicsClientId=cid)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.interval_s / self.substeps,
            numSolverIterations=10,
            deterministicOverlappingPairs=1,
            physicsClientId=cid,
        )
        self.ids: BodyIds = build_world(self.spec, cid)
        self.tick = 0
        self.paused = False
        self._cache: dict[object, object] = {}
        self._cache_tick = -1
        self._poses: dict[str, BodyPose] = {}  # the last pose of each body (see `snapshot`)
        seeds = np.random.SeedSequence(self.seed).spawn(len(self.spec.robots) + 1)
        self.noise_seed = int(seeds[-1].generate_state(1)[0])
        self.robots: list[RobotState] = []
        # robot name -> state, per device kind, for the robots with that device (filled on use)
        self._has_device: dict[str, dict[str, RobotState]] = {}
        for i, r in enumerate(self.spec.robots):
            st = RobotState(index=i, spec=r, body=self.ids.robots[r.name],
                        rng=np.random.default_rng(seeds[i]))
            st.x, st.y, st.yaw = r.pose
            st.z0 = st.z = r.body.height_m / 2 + 0.001
            st.odom = (0.0, 0.0, 0.0)
            self.robots.append(st)
        self._drive_limits = _drive_limits(self.robots)
        self.looks = Looks(self.spec, self.ids, cid)
        self.arrays = WorldArrays.from_spec(self.spec)
        self.robot_offset = np.array([r.body.offset_x_m for r in self.spec.robots])
        self.dyn_ids = ([self.ids.boxes[b.name] for b in self.spec.boxes]
                         + [self.ids.objects[o.name] for o in self.spec.objects])
        self.dyn_row = {n: i for i, n in enumerate(
            [b.name for b in self.spec.boxes] + [o.name for o in self.spec.objects])}
        self._dyn_kinds = ["box"] * len(self.spec.boxes) + ["object"] * len(self.spec.objects)
        self._obj_row = {o.name: i for i, o in enumerate(self.spec.objects)}
        self.obj_visible = np.ones(len(self.spec.objects), dtype=bool)
        self._blob_hidden = np.zeros(len(self.spec.objects), dtype=bool)
        self._marker_row = {m.name: i for i, m in enumerate(self.spec.markers)}
        wa = self.arrays
        # Footprint radii and tops: rectangles, then circles (all objects visible).
        self.fp_radius = np.concatenate([wa.fp_rect_radius, wa.fp_circle_radius])
        self.fp_top = np.concatenate([wa.fp_rect_top, wa.fp_circle_top])
        self.target_hidden: np.ndarray | None = None
        self.fixed_target_pos = np.array(
            [complex(m.x, m.y) for m in self.spec.markers]
            + [complex(c.x, c.y) for c in self.spec.chargers], dtype=np.complex128)
        self.fixed_target_head = np.ones(len(self.fixed_target_pos), dtype=np.complex128)
        self._body_kind: dict[str, tuple[str, int]] = {
            name: (kind, bid) for kind, ids in (("robot", self.ids.robots), ("box", self.ids.boxes),
                                               ("object", self.ids.objects),
                                               ("marker", self.ids.markers))
            for name, bid in ids.items()}
        self.hidden: set[str] = set()
        self.held: set[str] = set()
        self._marker_pos = {m.name: (m.x, m.y, 0.0) for m in self.spec.markers}
        self._box_specs = list(self.spec.boxes)
        log.debug("built world %s: %d robots, %d boxes, %d objects, seed %d, %s fidelity",
                  self.spec.name, len(self.robots), len(self.spec.boxes),
                  len(self.spec.objects), self.seed, self.fidelity)
        for model in self.models:
            model.build()

    def reset(self, seed: int | None = None) -> None:
        """Rebuild the world from its spec at tick 0 (optionally with a new seed)."""
        if seed is not None:
            self.seed = seed
        self.power_model.chargers_off.clear()
        self._build()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.sensing.caster.close()
            with contextlib.suppress(pb.error):  # already gone
                pb.disconnect(physicsClientId=self.physics_client)

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- clock -----------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        return self.tick * self.interval_s

    def set_paused(self, paused: bool) -> None:
        self.paused = bool(paused)

    def step(self, n: int = 1) -> int:
        """Advance n ticks (none while paused); returns the current tick."""
        if n < 0:
            raise ValueError("n must be >= 0")
        for _ in range(n):
            if self.paused:
                break
            self._step_once()
        return self.tick

    def _now(self) -> float:
        return self._clock() if self._clock is not None else 0.0

    def _step_once(self) -> None:
        cid = self.physics_client
        dt = self.interval_s
        t0 = self._now()
        sub_dt = dt / self.substeps
        # An upward speed of g*dt cancels one step of gravity (semi-implicit Euler); a robot
        # that a contact lifted or pressed down is brought back to its height within a tick.
        vz0 = _GRAVITY_MPS2 * sub_dt
        moving = _tick_speeds(self._drive_limits, dt, sub_dt, vz0)
        # (the hot PyBullet calls take the client id positionally: no keywords to parse)
        reset_vel = pb.resetBaseVelocity
        cos, sin = math.cos, math.sin
        for k in range(self.substeps):
            half = k + 0.5
            for body, v, w_sub, yaw0, w_off, vz, spin in moving:
                yaw = yaw0 + w_sub * half
                c, s = cos(yaw), sin(yaw)
                # Velocity of the body centre for a turn about the axle centre.
                reset_vel(body, (v * c - w_off * s, v * s + w_off * c, vz), spin, cid)
            pb.stepSimulation(physicsClientId=cid)
        self.tick += 1
        t1 = self._now()
        get_pose = pb.getBasePositionAndOrientation
        cos, sin = math.cos, math.sin
        moves: list[tuple[RobotState, float, float, float]] = []
        add_move = moves.append
        for st, _, _, off in self._drive_limits:
            pos, q = get_pose(st.body, cid)
            st.z = pos[2]
            yaw = _yaw_of(q)
            add_move((st, pos[0] - off * cos(yaw), pos[1] - off * sin(yaw), yaw))
        self.drive_model.advance_all(moves, dt)
        for st, x, y, yaw in moves:
            st.x, st.y, st.yaw = x, y, yaw
        t2 = self._now()
        self.power_model.advance(dt)
        t3 = self._now()
        for model in self._advanced_after_power:
            model.advance(dt)
        if self._clock is not None:
            t4 = self._now()
            tm = self.timings
            tm.physics_s += t1 - t0
            tm.other_s += (t2 - t1) + (t4 - t3)
            tm.battery_s += t3 - t2

    # ---- bodies ----------------------------------------------------------------------------
    def robot_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.spec.robots)

    def body_names(self) -> tuple[str, ...]:
        return tuple(self._body_kind)

    def _robot(self, name: str) -> RobotState:
        try:
            return self.robots[self._robot_index[name]]
        except KeyError:
            raise KeyError(f"no robot named {name!r}") from None

    def device(self, name: str, device: str) -> RobotState:
        try:
            return self._has_device[device][name]
        except KeyError:
            pass
        st = self._robot(name)
        if st.spec.devices.get(device) is None:
            raise ValueError(f"robot {name!r} has no {device}")
        self._has_device.setdefault(device, {})[name] = st
        return st

    def get_pose(self, name: str) -> tuple[float, float, float]:
        """Ground-truth pose (x, y, yaw); for robots, of the drive-axle centre."""
        i = self._robot_index.get(name)
        if i is not None:
            st = self.robots[i]
            return (st.x, st.y, st.yaw)
        if name not in self._body_kind:
            raise KeyError(f"no body named {name!r}")
        kind, _ = self._body_kind[name]
        if kind == "marker":
            return self._marker_pos[name]
        return self.tick_arrays.dyn_pose(name)

    def set_pose(self, name: str, x: float, y: float, yaw: float) -> None:
        """Teleport a body (at rest). Robots keep their odometry (a teleport is not motion)."""
        if name not in self._body_kind:
            raise KeyError(f"no body named {name!r}")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise ValueError(f"pose of {name!r} must be finite, got ({x}, {y}, {yaw})")
        kind, bid = self._body_kind[name]
        cid = self.physics_client
        if kind == "robot":
            st = self._robot(name)
            off = st.spec.body.offset_x_m
            pb.resetBasePositionAndOrientation(
                bid, (x + off * math.cos(yaw), y + off * math.sin(yaw), st.z0), _quat_yaw(yaw),
                physicsClientId=cid,
            )
            st.z = st.z0
            st.x, st.y, st.yaw = x, y, wrap_angle(yaw)
            st.v = st.w = 0.0
        else:
            height = {"box": lambda: next(b.size_z_m for b in self.spec.boxes if b.name == name),
                      "object": lambda: self.object_spec(name).height_m,
                      "marker": lambda: next(m.height_m for m in self.spec.markers
                                             if m.name == name)}[kind]()
            z = height / 2
            pb.resetBasePositionAndOrientation(bid, (x, y, z), _quat_yaw(yaw),
                                               physicsClientId=cid)
            if kind == "marker":
                self._marker_pos[name] = (x, y, wrap_angle(yaw))
                self.fixed_target_pos[self._marker_row[name]] = complex(x, y)
            if kind == "object":
                self.gripper_model.release_if_held(name)
                self.unhide_object(name)
        if kind != "marker":
            pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
        self.invalidate()

    def sensed_now(self) -> Sensed | None:
        if self._cache_tick != self.tick:
            return None
        return self._cache.get(self.sensing.key)  # type: ignore[return-value]

    def sense(self) -> Sensed:
        return self.sensing.sensed()

    def warm(self) -> None:
        """Compile the sensing kernels now (`SensingPass.warm`), before a client waits."""
        self.sensing.warm()

    def ptz_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.ptz_model.arrays()

    def object_spec(self, name: str) -> ObjectSpec:
        return next(o for o in self.spec.objects if o.name == name)

    def invalidate(self) -> None:
        self._cache.clear()

    def cached(self, key: object, compute: Callable[[], object]) -> object:
        if self._cache_tick != self.tick:
            self._cache.clear()
            self._cache_tick = self.tick
        if key not in self._cache:
            self._cache[key] = compute()
        return self._cache[key]

    # ---- drive: answered by the position2d model ----------------------------------------
    def set_velocity(self, robot: str, vx_mps: float, vyaw_radps: float) -> None:
        """Command forward and turn speed; clamped to the drive's limits."""
        self.drive_model.set_velocity(robot, vx_mps, vyaw_radps)

    def set_motor_power(self, robot: str, on: bool) -> None:
        self.drive_model.set_motor_power(robot, on)

    def motor_power(self, robot: str) -> bool:
        return self.drive_model.motor_power(robot)

    def drive_command(self, robot: str) -> tuple[float, float]:
        """The forward and turn speed the drive is steering towards now: the commanded
        velocity, or zero while the motors are off or the battery is flat."""
        return self.drive_model.drive_command(robot)

    def odometry(self, robot: str) -> Odometry:
        return self.drive_model.odometry(robot)

    def set_odometry(self, robot: str, x: float, y: float, yaw: float) -> None:
        self.drive_model.set_odometry(robot, x, y, yaw)

    # ---- objects hidden, held or stored ------------------------------------------------
    def set_looks(self, name: str, colour: int | None = None,
                  fiducial_id: int | None = None) -> None:
        """A body's colour or fiducial id as sensors see it from the next tick (`Looks`)."""
        if self.looks.change(name, colour, fiducial_id):  # the colours changed
            self.arrays = WorldArrays.from_spec(self.looks.applied())

    def update_visibility(self) -> None:
        """Held and stored objects are not footprints for the 2-D caster; stored ones are not
        blob targets either."""
        for name, i in self._obj_row.items():
            self.obj_visible[i] = name not in self.held and name not in self.hidden
        self._blob_hidden = np.array(
            [name in self.hidden for name in self._obj_row], dtype=bool)
        if self._blob_hidden.any():
            mask = np.zeros(self.arrays.t_radius.size, dtype=bool)
            start = self.arrays.n_robots + self.arrays.n_boxes
            mask[start:start + self._blob_hidden.size] = self._blob_hidden
            self.target_hidden = mask
        else:
            self.target_hidden = None
        self.invalidate()

    def hide_object(self, name: str) -> None:
        bid = self.ids.objects[name]
        idx = sorted(self.ids.objects).index(name)
        pb.resetBasePositionAndOrientation(bid, (idx * 1.0, 0.0, _HIDDEN_Z_M), (0, 0, 0, 1),
                                           physicsClientId=self.physics_client)
        pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=self.physics_client)
        pb.changeDynamics(bid, -1, mass=0.0, physicsClientId=self.physics_client)
        self.hidden.add(name)
        self.update_visibility()

    def unhide_object(self, name: str) -> None:
        if name in self.hidden:
            self.hidden.discard(name)
            self.update_visibility()
            pb.changeDynamics(self.ids.objects[name], -1, mass=self.object_spec(name).mass_kg,
                              physicsClientId=self.physics_client)

    # ---- devices: answered by their models ---------------------------------------------
    def sonar(self, robot: str) -> NDArray[np.float32]:
        """Sonar ranges (m), one per transducer, in the world file's transducer order."""
        return self.range_model.reading(robot, "sonar")

    def laser(self, robot: str) -> NDArray[np.float32]:
        """Laser ranges (m) from min_angle to max_angle (right to left)."""
        return self.range_model.reading(robot, "laser")

    def ranger(self, robot: str) -> NDArray[np.float64]:
        return self.range_model.reading(robot, "ranger")

    def set_scan_fan(self, robot: str, kind: str, fan: tuple[float, float, int] | None) -> None:
        """A laser's or ranger's rays: (first angle, spacing, count), or None: the world's."""
        self.range_model.set_fan(robot, kind, fan)

    def blobs(self, robot: str) -> tuple[Blob, ...]:
        """Blobs of the blobfinder's channel colours, by channel then area (largest first)."""
        return self.camera_model.blobs(robot)

    def camera_image(self, robot: str) -> NDArray[np.uint8]:
        """A rendered RGB image (H, W, 3) from the robot's camera (any fidelity)."""
        return self.camera_model.camera_image(robot)

    def bumpers(self, robot: str) -> tuple[bool, ...]:
        return self.bumper_model.bumpers(robot)

    def gripper(self, robot: str) -> GripperState:
        return self.gripper_model.gripper(robot)

    def gripper_command(self, robot: str, command: str) -> None:
        """"open", "close", "stop", "store" (held object into storage), "retrieve"."""
        self.gripper_model.gripper_command(robot, command)

    def ptz(self, robot: str) -> PtzState:
        return self.ptz_model.ptz(robot)

    def ptz_command(self, robot: str, pan: float, tilt: float, zoom: float) -> None:
        """Targets in radians (zoom = horizontal field of view), clamped to the head's limits;
        the head moves there at its maximum speeds."""
        self.ptz_model.ptz_command(robot, pan, tilt, zoom)

    def power(self, robot: str) -> PowerState:
        return self.power_model.power(robot)

    def set_battery(self, robot: str, fraction: float) -> None:
        """Set a battery's charge (0..1) directly, e.g. to script a low-battery test."""
        self.power_model.set_battery(robot, fraction)

    def set_charger_enabled(self, charger: str, enabled: bool) -> None:
        """Switch a charging pad off (a robot on it no longer charges) or on again; from the
        next step on, so it acts at a tick boundary."""
        self.power_model.set_charger_enabled(charger, enabled)

    def charger_enabled(self, charger: str) -> bool:
        return self.power_model.charger_enabled(charger)

    def fiducials(self, robot: str) -> tuple[Fiducial, ...]:
        """Robots and objects with a fiducial id within the detector's range and fan."""
        return self.tracking_model.fiducials(robot)

    def overhead(self) -> tuple[TrackedObject, ...]:
        """Robots, boxes, objects and markers inside the overhead camera's view."""
        return self.tracking_model.overhead()

    def snapshot(self) -> SceneSnapshot:
        def compute() -> SceneSnapshot:
            poses = self._poses
            make = _make_pose

            def pose(name: str, kind: str, x: float, y: float, yaw: float) -> BodyPose:
                # a body that has not moved keeps its pose object (readers compare by identity)
                bp = poses.get(name)
                if bp is None or bp.x != x or bp.y != y or bp.yaw != yaw or bp.kind != kind:
                    bp = poses[name] = make(name, kind, x, y, yaw)
                return bp

            bodies = [pose(st.spec.name, "robot", st.x, st.y, st.yaw) for st in self.robots]
            kinds = self._dyn_kinds
            hidden = self.hidden
            dynamic = self.tick_arrays.dynamic_poses().tolist()
            for name, kind, (x, y, yaw) in zip(self.dyn_row, kinds, dynamic, strict=True):
                if name not in hidden:
                    bodies.append(pose(name, kind, x, y, yaw))
            marker_pos = self._marker_pos
            bodies += [pose(m.name, "marker", *marker_pos[m.name]) for m in self.spec.markers]
            return SceneSnapshot(self.time_s, self.tick, tuple(bodies))

        return self.cached("snapshot", compute)  # type: ignore[return-value]


_DriveLimits = list[tuple[RobotState, float | None, float, float]]


def _drive_limits(robots: list[RobotState]) -> _DriveLimits:
    """Per robot: its state, the drive's accelerations (None without a drive), axle offset."""
    out: _DriveLimits = []
    for st in robots:
        p2d = st.spec.devices.position2d
        out.append((st, None if p2d is None else p2d.accel_mps2,
                    0.0 if p2d is None else p2d.yaw_accel_radps2, st.spec.body.offset_x_m))
    return out


_Moving = list[tuple[int, float, float, float, float, float, tuple[float, float, float]]]


def _tick_speeds(limits: _DriveLimits, dt: float, sub_dt: float, vz0: float) -> _Moving:
    """Ramp every robot's speeds towards its command for this tick and return, per robot,
    what is constant over the tick's substeps: body, forward speed, turn per substep, yaw,
    turn speed times the axle offset, upward speed, spin."""
    moving: _Moving = []
    add = moving.append
    for st, accel, yaw_accel, off in limits:
        if accel is None:
            st.v = st.w = v = w = 0.0
        else:
            tv, tw = st.target_v, st.target_w
            if not st.motors_on or (st.battery is not None and st.battery.flat):
                tv = tw = 0.0
            st.v = v = ramp(st.v, tv, accel * dt)
            st.w = w = ramp(st.w, tw, yaw_accel * dt)
        add((st.body, v, w * sub_dt, st.yaw, w * off, vz0 + (st.z0 - st.z) / dt,
             (0.0, 0.0, w)))
    return moving
