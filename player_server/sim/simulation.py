"""The Simulation: one PyBullet DIRECT client, stepped in integer ticks of interval_sim.

Each tick sets every robot's drive velocity (acceleration-limited) and runs
``physics_substeps`` physics steps, then reads the robots' poses to advance odometry, stall
flags, batteries, grippers and PTZ heads. Sensor readings are computed lazily on request and
cached until the next tick; range sensors of all robots that have been read before are cast in
one vectorised batch.
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pybullet as pb
from numpy.typing import NDArray

from player_server.sim import blobs as blobmod
from player_server.sim.battery import Battery
from player_server.sim.bodies import BodyIds, build_world
from player_server.sim.cast_kernel import CompiledCaster
from player_server.sim.drive import integrate, ramp, to_robot_frame, wrap_angle
from player_server.sim.fastsense import BlobPlan, Frame, RangePlan
from player_server.sim.footprint_cast import Footprints
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
from player_server.sim.world_arrays import WorldArrays
from worlds import RobotSpec, WorldSpec

log = logging.getLogger(__name__)

_make_pose = fast_constructor(BodyPose)
_make_tracked = fast_constructor(TrackedObject)

_GRIPPER_COMMANDS = ("open", "close", "stop", "store", "retrieve")
_HIDDEN_Z_M = -50.0
_GRAVITY_MPS2 = 9.81


def _yaw_of(q: tuple[float, float, float, float]) -> float:
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _quat_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


@dataclass
class _Gripper:
    state: str = "open"
    target: str = "open"
    remaining_s: float = 0.0
    holding: str | None = None
    constraint: int = -1
    stored: list[str] = field(default_factory=list)


@dataclass
class _Ptz:
    pan: float = 0.0
    tilt: float = 0.0
    zoom: float = 0.0
    pan_target: float = 0.0
    tilt_target: float = 0.0
    zoom_target: float = 0.0
    pan_speed: float = 0.0
    tilt_speed: float = 0.0


@dataclass
class _Robot:
    """Mutable per-robot state owned by the Simulation."""

    index: int
    spec: RobotSpec
    body: int
    rng: np.random.Generator
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    target_v: float = 0.0
    target_w: float = 0.0
    v: float = 0.0
    w: float = 0.0
    motors_on: bool = True
    odom: tuple[float, float, float] = (0.0, 0.0, 0.0)
    odom_v: tuple[float, float, float] = (0.0, 0.0, 0.0)
    stall: bool = False
    battery: Battery | None = None
    gripper: _Gripper | None = None
    ptz: _Ptz | None = None
    z0: float = 0.0  # body-centre height it glides at
    z: float = 0.0


@dataclass
class Timings:
    """Cumulative wall seconds spent per activity (for benchmarks), measured by the clock."""

    physics_s: float = 0.0
    ranges_s: float = 0.0
    blobs_s: float = 0.0
    battery_s: float = 0.0
    other_s: float = 0.0

    def as_dict(self) -> dict[str, float]:
        return dict(self.__dict__)


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
        self._client = pb.connect(pb.DIRECT)
        self._closed = False
        self._caster = CompiledCaster()
        self._robot_index = {r.name: i for i, r in enumerate(spec.robots)}
        self._active_ranges: set[tuple[int, str]] = set()
        self._active_cameras: set[int] = set()
        self._chargers_off: set[str] = set()
        self._build()

    # ---- lifecycle -------------------------------------------------------------------------
    def _build(self) -> None:
        cid = self._client
        pb.resetSimulation(physicsClientId=cid)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.interval_s / self.substeps,
            numSolverIterations=10,
            deterministicOverlappingPairs=1,
            physicsClientId=cid,
        )
        self._ids: BodyIds = build_world(self.spec, cid)
        self.tick = 0
        self.paused = False
        self._cache: dict[object, object] = {}
        self._cache_tick = -1
        self._colours: dict[str, int] | None = None  # see `_spec_colours`
        self._poses: dict[str, BodyPose] = {}  # the last pose of each body (see `snapshot`)
        # the last fast reading of each range sensor and camera (see `_sense_fast`)
        self._last_ranges: dict[tuple[int, str], np.ndarray] = {}
        self._last_blobs: dict[int, tuple[Blob, ...]] = {}
        # the last pose of each body the overhead camera saw, and what it made of it
        self._seen: dict[str, tuple[BodyPose, TrackedObject]] = {}
        seeds = np.random.SeedSequence(self.seed).spawn(len(self.spec.robots) + 1)
        self._noise_seed = int(seeds[-1].generate_state(1)[0])
        self._robots: list[_Robot] = []
        self._has_device: dict[tuple[str, str], _Robot] = {}
        for i, r in enumerate(self.spec.robots):
            st = _Robot(index=i, spec=r, body=self._ids.robots[r.name],
                        rng=np.random.default_rng(seeds[i]))
            st.x, st.y, st.yaw = r.pose
            st.z0 = st.z = r.body.height_m / 2 + 0.001
            st.odom = (0.0, 0.0, 0.0)
            d = r.devices
            if d.power is not None:
                st.battery = Battery.full_as_specified(d.power)
            if d.gripper is not None:
                st.gripper = _Gripper()
            if d.ptz is not None and d.camera is not None:
                st.ptz = _Ptz(zoom=d.camera.fov_h_rad, zoom_target=d.camera.fov_h_rad)
            self._robots.append(st)
        self._arrays = WorldArrays.from_spec(self.spec)
        self._robot_offset = np.array([r.body.offset_x_m for r in self.spec.robots])
        self._dyn_ids = ([self._ids.boxes[b.name] for b in self.spec.boxes]
                         + [self._ids.objects[o.name] for o in self.spec.objects])
        self._dyn_row = {n: i for i, n in enumerate(
            [b.name for b in self.spec.boxes] + [o.name for o in self.spec.objects])}
        self._dyn_kinds = ["box"] * len(self.spec.boxes) + ["object"] * len(self.spec.objects)
        self._obj_row = {o.name: i for i, o in enumerate(self.spec.objects)}
        self._obj_visible = np.ones(len(self.spec.objects), dtype=bool)
        self._blob_hidden = np.zeros(len(self.spec.objects), dtype=bool)
        self._marker_row = {m.name: i for i, m in enumerate(self.spec.markers)}
        wa = self._arrays
        # Footprint radii and tops: rectangles, then circles (all objects visible).
        self._fp_radius = np.concatenate([wa.fp_rect_radius, wa.fp_circle_radius])
        self._fp_top = np.concatenate([wa.fp_rect_top, wa.fp_circle_top])
        self._range_plans: dict[tuple[tuple[int, str], ...], RangePlan] = {}
        self._blob_plans: dict[tuple[int, ...], BlobPlan] = {}
        self._has_ptz = any(st.ptz is not None for st in self._robots)
        self._zeros_robots = np.zeros(len(self._robots))
        self._zeros = np.zeros(256)
        self._target_hidden: np.ndarray | None = None
        self._fixed_target_pos = np.array(
            [complex(m.x, m.y) for m in self.spec.markers]
            + [complex(c.x, c.y) for c in self.spec.chargers], dtype=np.complex128)
        self._fixed_target_head = np.ones(len(self._fixed_target_pos), dtype=np.complex128)
        self._body_kind: dict[str, tuple[str, int]] = {}
        for r in self.spec.robots:
            self._body_kind[r.name] = ("robot", self._ids.robots[r.name])
        for b in self.spec.boxes:
            self._body_kind[b.name] = ("box", self._ids.boxes[b.name])
        for o in self.spec.objects:
            self._body_kind[o.name] = ("object", self._ids.objects[o.name])
        for m in self.spec.markers:
            self._body_kind[m.name] = ("marker", self._ids.markers[m.name])
        self._hidden: set[str] = set()
        self._held: set[str] = set()
        self._marker_pos = {m.name: (m.x, m.y, 0.0) for m in self.spec.markers}
        self._box_specs = list(self.spec.boxes)
        log.debug("built world %s: %d robots, %d boxes, %d objects, seed %d, %s fidelity",
                  self.spec.name, len(self._robots), len(self.spec.boxes),
                  len(self.spec.objects), self.seed, self.fidelity)
        self._obj_specs = list(self.spec.objects)

    def reset(self, seed: int | None = None) -> None:
        """Rebuild the world from its spec at tick 0 (optionally with a new seed)."""
        if seed is not None:
            self.seed = seed
        self._chargers_off.clear()
        self._build()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            with contextlib.suppress(pb.error):  # already gone
                pb.disconnect(physicsClientId=self._client)

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
        cid = self._client
        dt = self.interval_s
        t0 = self._now()
        robots = self._robots
        for st in robots:
            p2d = st.spec.devices.position2d
            if p2d is None:
                st.v = st.w = 0.0
                continue
            tv, tw = st.target_v, st.target_w
            if not st.motors_on or (st.battery is not None and st.battery.flat):
                tv = tw = 0.0
            st.v = ramp(st.v, tv, p2d.accel_mps2 * dt)
            st.w = ramp(st.w, tw, p2d.yaw_accel_radps2 * dt)
        sub_dt = dt / self.substeps
        # An upward speed of g*dt cancels one step of gravity (semi-implicit Euler); a robot
        # that a contact lifted or pressed down is brought back to its height within a tick.
        vz0 = _GRAVITY_MPS2 * sub_dt
        reset_vel = pb.resetBaseVelocity
        for k in range(self.substeps):
            for st in robots:
                vz = vz0 + (st.z0 - st.z) / dt
                yaw = st.yaw + st.w * sub_dt * (k + 0.5)
                c, s = math.cos(yaw), math.sin(yaw)
                off = st.spec.body.offset_x_m
                # Velocity of the body centre for a turn about the axle centre.
                vx = st.v * c - st.w * off * s
                vy = st.v * s + st.w * off * c
                reset_vel(st.body, (vx, vy, vz), (0.0, 0.0, st.w), physicsClientId=cid)
            pb.stepSimulation(physicsClientId=cid)
        self.tick += 1
        t1 = self._now()
        get_pose = pb.getBasePositionAndOrientation
        for st in robots:
            pos, q = get_pose(st.body, physicsClientId=cid)
            st.z = pos[2]
            yaw = _yaw_of(q)
            off = st.spec.body.offset_x_m
            x = pos[0] - off * math.cos(yaw)
            y = pos[1] - off * math.sin(yaw)
            self._advance_odometry(st, x, y, yaw, dt)
            st.x, st.y, st.yaw = x, y, yaw
        t2 = self._now()
        for st in robots:
            if st.battery is not None:
                self._advance_battery(st, dt)
        t3 = self._now()
        for st in robots:
            if st.gripper is not None:
                self._advance_gripper(st, dt)
            if st.ptz is not None:
                self._advance_ptz(st, dt)
        if self._clock is not None:
            t4 = self._now()
            tm = self.timings
            tm.physics_s += t1 - t0
            tm.other_s += (t2 - t1) + (t4 - t3)
            tm.battery_s += t3 - t2

    def _advance_odometry(self, st: _Robot, x: float, y: float, yaw: float, dt: float) -> None:
        fwd, left, turn = to_robot_frame(st.x, st.y, st.yaw, x, y, yaw)
        p2d = st.spec.devices.position2d
        if p2d is not None and (p2d.odom_noise_fraction > 0 or p2d.odom_yaw_noise_fraction > 0):
            n = st.rng.standard_normal(2)
            fwd *= 1.0 + p2d.odom_noise_fraction * float(n[0])
            left *= 1.0 + p2d.odom_noise_fraction * float(n[0])
            turn *= 1.0 + p2d.odom_yaw_noise_fraction * float(n[1])
        st.odom = integrate(*st.odom, fwd, left, turn)
        st.odom_v = (fwd / dt, left / dt, turn / dt)
        commanded = abs(st.v) * dt
        st.stall = commanded > 0.01 * dt and math.hypot(fwd, left) < 0.3 * commanded

    def _advance_battery(self, st: _Robot, dt: float) -> None:
        b = st.battery
        assert b is not None
        p2d = st.spec.devices.position2d
        frac = 0.0
        if p2d is not None:
            frac = 0.5 * (abs(st.v) / p2d.max_speed_mps + abs(st.w) / p2d.max_yaw_rate_radps)
        charge = 0.0
        for c in self.spec.chargers:
            if c.name in self._chargers_off:
                continue
            if (st.x - c.x) ** 2 + (st.y - c.y) ** 2 <= c.radius_m ** 2:
                charge = c.rate_w
                break
        b.update(dt, b.draw_w(frac), charge)

    # ---- bodies ----------------------------------------------------------------------------
    def robot_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.spec.robots)

    def body_names(self) -> tuple[str, ...]:
        return tuple(self._body_kind)

    def _robot(self, name: str) -> _Robot:
        try:
            return self._robots[self._robot_index[name]]
        except KeyError:
            raise KeyError(f"no robot named {name!r}") from None

    def _device(self, name: str, device: str) -> _Robot:
        st = self._has_device.get((name, device))
        if st is None:
            st = self._robot(name)
            if getattr(st.spec.devices, device) is None:
                raise ValueError(f"robot {name!r} has no {device}")
            self._has_device[(name, device)] = st
        return st

    def get_pose(self, name: str) -> tuple[float, float, float]:
        """Ground-truth pose (x, y, yaw); for robots, of the drive-axle centre."""
        if name in self._robot_index:
            st = self._robot(name)
            return (st.x, st.y, st.yaw)
        if name not in self._body_kind:
            raise KeyError(f"no body named {name!r}")
        kind, _ = self._body_kind[name]
        if kind == "marker":
            return self._marker_pos[name]
        return self._dyn_pose(name)

    def set_pose(self, name: str, x: float, y: float, yaw: float) -> None:
        """Teleport a body (at rest). Robots keep their odometry (a teleport is not motion)."""
        if name not in self._body_kind:
            raise KeyError(f"no body named {name!r}")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise ValueError(f"pose of {name!r} must be finite, got ({x}, {y}, {yaw})")
        kind, bid = self._body_kind[name]
        cid = self._client
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
            z = {"box": lambda: self._box_spec(name).size_z_m / 2,
                 "object": lambda: self._obj_spec(name).height_m / 2,
                 "marker": lambda: self._marker_spec_height(name) / 2}[kind]()
            pb.resetBasePositionAndOrientation(bid, (x, y, z), _quat_yaw(yaw),
                                               physicsClientId=cid)
            if kind == "marker":
                self._marker_pos[name] = (x, y, wrap_angle(yaw))
                self._fixed_target_pos[self._marker_row[name]] = complex(x, y)
            if kind == "object":
                self._release_if_held(name)
                self._unhide(name)
        if kind != "marker":
            pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
        self._invalidate()

    def _box_spec(self, name: str):
        return next(b for b in self.spec.boxes if b.name == name)

    def _obj_spec(self, name: str):
        return next(o for o in self.spec.objects if o.name == name)

    def _marker_spec_height(self, name: str) -> float:
        return next(m.height_m for m in self.spec.markers if m.name == name)

    def _invalidate(self) -> None:
        self._cache.clear()

    def _cached(self, key: object, compute: Callable[[], object]) -> object:
        if self._cache_tick != self.tick:
            self._cache.clear()
            self._cache_tick = self.tick
        if key not in self._cache:
            self._cache[key] = compute()
        return self._cache[key]

    # ---- drive -----------------------------------------------------------------------------
    def set_velocity(self, robot: str, vx_mps: float, vyaw_radps: float) -> None:
        """Command forward and turn speed; clamped to the drive's limits."""
        st = self._device(robot, "position2d")
        p2d = st.spec.devices.position2d
        assert p2d is not None
        if not (math.isfinite(vx_mps) and math.isfinite(vyaw_radps)):
            raise ValueError("velocity must be finite")
        st.target_v = max(-p2d.max_speed_mps, min(p2d.max_speed_mps, float(vx_mps)))
        st.target_w = max(-p2d.max_yaw_rate_radps, min(p2d.max_yaw_rate_radps,
                                                       float(vyaw_radps)))

    def set_motor_power(self, robot: str, on: bool) -> None:
        self._device(robot, "position2d").motors_on = bool(on)

    def motor_power(self, robot: str) -> bool:
        return self._device(robot, "position2d").motors_on

    def drive_command(self, robot: str) -> tuple[float, float]:
        """The forward and turn speed the drive is steering towards now: the commanded
        velocity, or zero while the motors are off or the battery is flat."""
        st = self._device(robot, "position2d")
        if not st.motors_on or (st.battery is not None and st.battery.flat):
            return 0.0, 0.0
        return st.target_v, st.target_w

    def odometry(self, robot: str) -> Odometry:
        st = self._device(robot, "position2d")
        x, y, yaw = st.odom
        vx, vy, vyaw = st.odom_v
        return Odometry(x, y, yaw, vx, vy, vyaw, st.stall)

    def set_odometry(self, robot: str, x: float, y: float, yaw: float) -> None:
        st = self._device(robot, "position2d")
        st.odom = (float(x), float(y), wrap_angle(float(yaw)))

    # ---- per-tick arrays ------------------------------------------------------------------
    def _dynamic_poses(self) -> NDArray[np.float64]:
        """(n_boxes + n_objects, 3) poses, boxes first."""
        return self._dynamic()[0]

    def _dynamic(self) -> tuple[NDArray[np.float64], NDArray[np.complex128],
                                NDArray[np.complex128]]:
        """Boxes' and objects' poses (n, 3), positions x + iy and headings exp(i yaw), read
        from PyBullet in one pass per tick."""

        def compute() -> tuple[NDArray[np.float64], NDArray[np.complex128],
                               NDArray[np.complex128]]:
            cid = self._client
            get = pb.getBasePositionAndOrientation
            rows, pos, head = [], [], []
            for bid in self._dyn_ids:
                p, q = get(bid, physicsClientId=cid)
                yaw = _yaw_of(q)
                rows.append((p[0], p[1], yaw))
                pos.append(complex(p[0], p[1]))
                head.append(complex(math.cos(yaw), math.sin(yaw)))
            return (np.array(rows, dtype=np.float64).reshape(-1, 3),
                    np.array(pos, dtype=np.complex128), np.array(head, dtype=np.complex128))

        return self._cached("dynamic", compute)  # type: ignore[return-value]

    def _dyn_pose(self, name: str) -> tuple[float, float, float]:
        x, y, yaw = self._dynamic_poses()[self._dyn_row[name]].tolist()
        return (x, y, yaw)

    def _footprints(self) -> Footprints:
        """This tick's footprints: static obstacles, robots' bodies and boxes (rectangles),
        static cylinders and the objects not held or stored (circles)."""

        def compute() -> Footprints:
            wa = self._arrays
            frame = self._frame()
            _, pos, head = self._dynamic()
            nb = wa.n_boxes
            vis = self._obj_visible
            if vis.all():
                circles, c_radius, c_top = pos[nb:], self._fp_radius, self._fp_top
            else:
                keep = np.concatenate([np.ones(wa.static_circle_centre.size, dtype=bool), vis])
                circles = pos[nb:][vis]
                c_radius, c_top = self._fp_radius[keep], self._fp_top[keep]
            return Footprints(
                centre=np.concatenate([wa.static_rect_centre, frame.body, pos[:nb],
                                       wa.static_circle_centre, circles]),
                head_conj=np.concatenate([wa.static_rect_head, frame.head,
                                          head[:nb]]).conjugate(),
                half=wa.fp_half,
                radius=c_radius,
                top=c_top,
            )

        return self._cached("footprints", compute)  # type: ignore[return-value]

    def _cameras(self, idx: list[int]) -> blobmod.Cameras:
        frame = self._frame()
        ii = np.array(idx, dtype=np.int64)
        ptz = [self._robots[i].ptz for i in idx]
        pan = np.array([p.pan if p is not None else 0.0 for p in ptz])
        tilt = np.array([p.tilt if p is not None else 0.0 for p in ptz])
        zoom = np.array([p.zoom if p is not None else 0.0 for p in ptz])
        return self._arrays.cameras(ii, frame.pos.real[ii], frame.pos.imag[ii], frame.yaw[ii],
                                    pan, tilt, zoom)

    # ---- sensing batch ---------------------------------------------------------------------
    def _sensed(self) -> dict[str, dict]:
        """This tick's readings of every active range sensor and blobfinder, computed together
        (one ray cast) on first use."""
        cache = self._cached(("sensed", self.fidelity), lambda: {"ranges": {}, "blobs": {}})
        assert isinstance(cache, dict)
        rkeys = tuple(sorted(k for k in self._active_ranges if k not in cache["ranges"]))
        cams = sorted(i for i in self._active_cameras if i not in cache["blobs"])
        if rkeys or cams:
            if self.fidelity == "render":
                self._sense_render(rkeys, cams, cache)
            else:
                self._sense_fast(rkeys, cams, cache)
        return cache

    def _frame(self) -> Frame:
        def compute() -> Frame:
            pos, head, yaw, body = [], [], [], []
            for st in self._robots:
                h = complex(math.cos(st.yaw), math.sin(st.yaw))
                p = complex(st.x, st.y)
                pos.append(p)
                head.append(h)
                yaw.append(st.yaw)
                body.append(p + h * st.spec.body.offset_x_m)
            return Frame(np.array(pos, dtype=np.complex128),
                         np.array(head, dtype=np.complex128), np.array(yaw),
                         np.array(body, dtype=np.complex128))

        return self._cached("frame", compute)  # type: ignore[return-value]

    def _ptz_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = len(self._robots)
        if not self._has_ptz:
            z = self._zeros_robots
            return z, z, z
        pan, tilt, zoom = np.zeros(n), np.zeros(n), np.zeros(n)
        for st in self._robots:
            if st.ptz is not None:
                pan[st.index], tilt[st.index], zoom[st.index] = st.ptz.pan, st.ptz.tilt, \
                    st.ptz.zoom
        return pan, tilt, zoom

    def _target_poses(self, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        _, pos, head = self._dynamic()
        t_pos = np.concatenate([frame.body, pos, self._fixed_target_pos])
        t_head = np.concatenate([frame.head, head, self._fixed_target_head])
        return t_pos, t_head

    def _sense_fast(self, rkeys: tuple[tuple[int, str], ...], cams: list[int],
                    cache: dict) -> None:
        t0 = self._now()
        frame = self._frame()
        origins: list[np.ndarray] = []
        dirs: list[np.ndarray] = []
        maxr: list[np.ndarray] = []
        zs: list[np.ndarray] = []
        own: list[np.ndarray] = []
        plan = None
        if rkeys:
            plan = self._range_plan(rkeys)
            o, d = plan.rays(frame)
            origins.append(o)
            dirs.append(d)
            maxr.append(plan.max_range)
            zs.append(plan.z)
            own.append(plan.own)
        n_range = sum(o.size for o in origins)
        bplan = pending = None
        if cams:
            cam_key = tuple(cams)
            bplan = self._blob_plans.get(cam_key)
            if bplan is None:
                bplan = self._blob_plans[cam_key] = BlobPlan.build(cam_key, self._arrays)
            t_pos, t_head = self._target_poses(frame)
            pan, _, zoom = self._ptz_arrays()
            pending = bplan.pending(frame, t_pos, t_head, pan, zoom, self._target_hidden)
            if pending.pair.size:
                # Occlusion: the ray from the camera to the target's centre must reach the
                # target's near side (cast at ground level: every footprint can block it).
                origins.append(pending.origin)
                dirs.append(pending.direction)
                maxr.append(pending.dist)
                zs.append(self._zeros_for(pending.pair.size))
                own.append(bplan.own[pending.pair])
        t1 = self._now()
        hits = np.zeros(0)
        if origins:
            o = np.concatenate(origins) if len(origins) > 1 else origins[0]
            d = np.concatenate(dirs) if len(dirs) > 1 else dirs[0]
            hits = self._caster.cast(o, d, np.concatenate(maxr) if len(maxr) > 1 else maxr[0],
                                     np.concatenate(zs) if len(zs) > 1 else zs[0],
                                     self._footprints(), self._arrays.room,
                                     np.concatenate(own) if len(own) > 1 else own[0])
        t2 = self._now()
        # a reading equal to the last one is handed out as the same object (a robot standing
        # still in a still world), so that readers can tell it has not changed by identity
        if plan is not None:
            fresh = plan.split(hits[:n_range])
            last = self._last_ranges
            for key, reading in fresh.items():
                old = last.get(key)
                if (old is not None and old.dtype == reading.dtype
                        and old.tobytes() == reading.tobytes()):
                    fresh[key] = old
                else:
                    last[key] = reading
            cache["ranges"].update(fresh)
        t3 = self._now()
        if bplan is not None and pending is not None:
            visible = hits[n_range:] >= pending.near - 0.05
            pan, tilt, zoom = self._ptz_arrays()
            last_blobs = self._last_blobs
            seen = cache["blobs"]
            for cam, blobs in zip(cams, bplan.project(pending, visible, pan, tilt, zoom),
                                  strict=True):
                old_blobs = last_blobs.get(cam)
                if old_blobs is not None and old_blobs == blobs:
                    blobs = old_blobs
                else:
                    last_blobs[cam] = blobs
                seen[cam] = blobs
        if self._clock is not None:
            t4 = self._now()
            share = n_range / max(1, hits.size)
            self.timings.ranges_s += (t3 - t2) + (t2 - t1) * share
            self.timings.blobs_s += (t1 - t0) + (t4 - t3) + (t2 - t1) * (1 - share)

    def _range_plan(self, keys: tuple[tuple[int, str], ...]) -> RangePlan:
        plan = self._range_plans.get(keys)
        if plan is None:
            plan = self._range_plans[keys] = RangePlan.build(keys, self.spec.robots,
                                                              self._arrays)
        return plan

    def _zeros_for(self, n: int) -> np.ndarray:
        if self._zeros.size < n:
            self._zeros = np.zeros(max(n, 2 * self._zeros.size))
        return self._zeros[:n]

    def _sense_render(self, rkeys: tuple[tuple[int, str], ...], cams: list[int],
                      cache: dict) -> None:
        t0 = self._now()
        if rkeys:
            plan = self._range_plan(rkeys)
            o, d = plan.rays(self._frame())
            hits = self._render_rays(plan, o, d)
            cache["ranges"].update(plan.split(hits))
        t1 = self._now()
        if cams:
            camarr = self._cameras(cams)
            for j, i in enumerate(cams):
                bf = self.spec.robots[i].devices.blobfinder
                assert bf is not None
                pose = camarr.pose(j)
                rgb, depth = self._render_camera(pose)
                focal = (pose.width / 2) / math.tan(pose.fov_h / 2)
                cache["blobs"][i] = blobmod.detect(rgb, depth, bf.channels,
                                                   bf.colour_tolerance, bf.min_area_px, focal)
        if self._clock is not None:
            self.timings.ranges_s += t1 - t0
            self.timings.blobs_s += self._now() - t1

    def _render_rays(self, plan: RangePlan, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        """PyBullet rays at the sensor height, starting where each ray leaves its own body."""
        frame = self._frame()
        r = plan.robot
        head = frame.head[r]
        body = frame.pos[r] + head * self._robot_offset[r]
        half_l = self._arrays.rect_half_x[r]
        half_w = self._arrays.rect_half_y[r]
        # Ray origin and direction in the body frame; slab exit distance of the body box.
        p = (o - body) * head.conjugate()
        q = d * head.conjugate()
        px, py, qx, qy = p.real, p.imag, q.real, q.imag
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(np.abs(qx) > 1e-12, (np.sign(qx) * half_l - px) / qx, np.inf)
            ty = np.where(np.abs(qy) > 1e-12, (np.sign(qy) * half_w - py) / qy, np.inf)
        inside = (np.abs(px) <= half_l) & (np.abs(py) <= half_w)
        skip = np.where(inside, np.maximum(np.minimum(tx, ty), 0.0) + 1e-3, 0.0)
        ox, oy, dx, dy = o.real, o.imag, d.real, d.imag
        max_r = plan.max_range
        z = plan.z
        frm = np.stack([ox + dx * skip, oy + dy * skip, z], axis=1).tolist()
        to = np.stack([ox + dx * max_r, oy + dy * max_r, z], axis=1).tolist()
        out = np.array(max_r, copy=True)
        batch = 16000
        cid = self._client
        for i in range(0, len(frm), batch):
            res = pb.rayTestBatch(frm[i:i + batch], to[i:i + batch], physicsClientId=cid)
            for j, hit in enumerate(res):
                if hit[0] >= 0:
                    k = i + j
                    out[k] = skip[k] + hit[2] * (max_r[k] - skip[k])
        return out

    def _ranges(self, robot: str, kind: str) -> np.ndarray:
        st = self._device(robot, kind)
        key = (st.index, kind)
        if self._cache_tick == self.tick:
            done = self._cache.get(("sensed", self.fidelity))
            if done is not None and key in done["ranges"]:  # type: ignore[index]
                return done["ranges"][key]  # type: ignore[index]
        self._active_ranges.add(key)
        return self._sensed()["ranges"][key]

    def sonar(self, robot: str) -> NDArray[np.float32]:
        """Sonar ranges (m), one per transducer, in the world file's transducer order."""
        return self._ranges(robot, "sonar")

    def laser(self, robot: str) -> NDArray[np.float32]:
        """Laser ranges (m) from min_angle to max_angle (right to left)."""
        return self._ranges(robot, "laser")

    def ranger(self, robot: str) -> NDArray[np.float64]:
        return self._ranges(robot, "ranger")

    # ---- cameras ---------------------------------------------------------------------------
    def blobs(self, robot: str) -> tuple[Blob, ...]:
        """Blobs of the blobfinder's channel colours, by channel then area (largest first)."""
        st = self._device(robot, "blobfinder")
        if self._cache_tick == self.tick:
            done = self._cache.get(("sensed", self.fidelity))
            if done is not None and st.index in done["blobs"]:  # type: ignore[index]
                return done["blobs"][st.index]  # type: ignore[index]
        self._active_cameras.add(st.index)
        return self._sensed()["blobs"][st.index]

    def _render_camera(
        self, cam: blobmod.CameraPose
    ) -> tuple[NDArray[np.uint8], NDArray[np.float64]]:
        near, far = 0.05, max(cam.max_range, 1.0)
        ct, st_ = math.cos(cam.tilt), math.sin(cam.tilt)
        eye = [cam.x, cam.y, cam.z]
        target = [cam.x + math.cos(cam.yaw) * ct, cam.y + math.sin(cam.yaw) * ct, cam.z + st_]
        view = pb.computeViewMatrix(eye, target, [0, 0, 1], physicsClientId=self._client)
        aspect = cam.width / cam.height
        fov_v = math.degrees(2 * math.atan(math.tan(cam.fov_h / 2) / aspect))
        proj = pb.computeProjectionMatrixFOV(fov_v, aspect, near, far,
                                             physicsClientId=self._client)
        _, _, px, dbuf, _ = pb.getCameraImage(
            cam.width, cam.height, view, proj, shadow=0, lightAmbientCoeff=1.0,
            lightDiffuseCoeff=0.0, lightSpecularCoeff=0.0, renderer=pb.ER_TINY_RENDERER,
            physicsClientId=self._client,
        )
        rgba = np.asarray(px, dtype=np.uint8).reshape(cam.height, cam.width, 4)
        d = np.asarray(dbuf, dtype=np.float64).reshape(cam.height, cam.width)
        depth = far * near / (far - (far - near) * d)
        return np.ascontiguousarray(rgba[:, :, :3]), depth

    def camera_image(self, robot: str) -> NDArray[np.uint8]:
        """A rendered RGB image (H, W, 3) from the robot's camera (any fidelity)."""
        st = self._device(robot, "camera")

        def compute() -> NDArray[np.uint8]:
            img, _ = self._render_camera(self._cameras([st.index]).pose(0))
            img.setflags(write=False)
            return img

        return self._cached(("image", st.index), compute)  # type: ignore[return-value]

    # ---- bumpers ---------------------------------------------------------------------------
    def bumpers(self, robot: str) -> tuple[bool, ...]:
        st = self._device(robot, "bumper")

        def compute() -> tuple[bool, ...]:
            spec = st.spec.devices.bumper
            assert spec is not None
            body = st.spec.body
            contacts = pb.getContactPoints(bodyA=st.body, physicsClientId=self._client)
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            # Contact manifolds report the corners of a touching patch, so each touching body
            # presses every panel whose lateral extent overlaps its patch on that end.
            spans: dict[tuple[int, bool], list[float]] = {}
            reach = 0.6 * body.length_m / 2
            for cp in contacts:
                other = cp[2]
                if other == self._ids.floor or other == st.body:
                    continue
                wx, wy = cp[5][0] - st.x, cp[5][1] - st.y
                lx, ly = c * wx + s * wy - body.offset_x_m, -s * wx + c * wy
                if abs(lx) < reach:
                    continue  # a side contact: no panels there
                span = spans.setdefault((other, lx > 0), [ly, ly])
                span[0], span[1] = min(span[0], ly), max(span[1], ly)
            pressed = [False] * len(spec.segments)
            for (_, front), (lo, hi) in spans.items():
                for i, seg in enumerate(spec.segments):
                    if (seg.x > body.offset_x_m) != front:
                        continue
                    half = seg.length_m / 2 * abs(math.cos(seg.yaw))
                    if seg.y - half <= hi + 0.01 and seg.y + half >= lo - 0.01:
                        pressed[i] = True
            return tuple(pressed)

        return self._cached(("bumpers", st.index), compute)  # type: ignore[return-value]

    # ---- gripper ---------------------------------------------------------------------------
    def _grip_zone(self, st: _Robot) -> str | None:
        """The nearest grippable object between the paddles, if any."""
        g = st.spec.devices.gripper
        assert g is not None
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        best, best_d = None, math.inf
        for o in self._obj_specs:
            if o.name in self._hidden or o.name in self._held:
                continue
            if o.radius_m > g.max_object_radius_m:
                continue
            x, y, _ = self._dyn_pose(o.name)
            wx, wy = x - st.x, y - st.y
            lx, ly = c * wx + s * wy, -s * wx + c * wy
            if abs(ly) <= g.width_m / 2 and abs(lx - g.pose.x) <= g.depth_m / 2 + o.radius_m:
                d = abs(lx - g.pose.x)
                if d < best_d:
                    best, best_d = o.name, d
        return best

    def gripper(self, robot: str) -> GripperState:
        st = self._device(robot, "gripper")

        def compute() -> GripperState:
            g = st.gripper
            spec = st.spec.devices.gripper
            assert g is not None and spec is not None
            beams = 0
            if g.holding is not None:
                beams = 3
            elif self._grip_zone(st) is not None:
                beams = 1
            return GripperState(g.state, beams, g.holding, len(g.stored), spec.capacity)

        return self._cached(("gripper", st.index), compute)  # type: ignore[return-value]

    def gripper_command(self, robot: str, command: str) -> None:
        """"open", "close", "stop", "store" (held object into storage), "retrieve"."""
        st = self._device(robot, "gripper")
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        if command not in _GRIPPER_COMMANDS:
            raise ValueError(f"gripper command must be one of {_GRIPPER_COMMANDS}, not "
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
                self._hide(name)
                g.stored.append(name)
        elif command == "retrieve" and g.stored and g.holding is None:
            name = g.stored.pop()
            self._unhide(name)
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            ospec = self._obj_spec(name)
            bid = self._ids.objects[name]
            pb.resetBasePositionAndOrientation(
                bid, (st.x + c * spec.pose.x, st.y + s * spec.pose.x, ospec.height_m / 2),
                (0, 0, 0, 1), physicsClientId=self._client)
            pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=self._client)
            self._grab(st, name)
            g.state = "closed"
            g.target = "closed"
        self._invalidate()

    def _start_paddles(self, st: _Robot, target: str) -> None:
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        g.target = target
        g.state = "moving"
        g.remaining_s = spec.move_time_s
        if spec.move_time_s <= 0:
            self._finish_gripper(st)

    def _advance_gripper(self, st: _Robot, dt: float) -> None:
        g = st.gripper
        assert g is not None
        if g.state == "moving" and g.target in ("open", "closed"):
            g.remaining_s -= dt
            if g.remaining_s <= 1e-9:
                self._finish_gripper(st)

    def _finish_gripper(self, st: _Robot) -> None:
        g = st.gripper
        assert g is not None
        g.state = g.target
        g.remaining_s = 0.0
        if g.state == "closed" and g.holding is None:
            name = self._grip_zone(st)
            if name is not None:
                self._grab(st, name)

    def _grab(self, st: _Robot, name: str) -> None:
        g = st.gripper
        spec = st.spec.devices.gripper
        assert g is not None and spec is not None
        cid = self._client
        bid = self._ids.objects[name]
        ospec = self._obj_spec(name)
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
        self._held.add(name)
        self._update_visibility()
        self._invalidate()

    def _release(self, st: _Robot) -> None:
        g = st.gripper
        assert g is not None
        if g.holding is None:
            return
        cid = self._client
        if g.constraint >= 0:
            pb.removeConstraint(g.constraint, physicsClientId=cid)
        bid = self._ids.objects[g.holding]
        pb.setCollisionFilterPair(st.body, bid, -1, -1, 1, physicsClientId=cid)
        self._held.discard(g.holding)
        self._update_visibility()
        g.holding = None
        g.constraint = -1
        self._invalidate()

    def _update_visibility(self) -> None:
        """Held and stored objects are not footprints for the 2-D caster; stored ones are not
        blob targets either."""
        for name, i in self._obj_row.items():
            self._obj_visible[i] = name not in self._held and name not in self._hidden
        self._blob_hidden = np.array(
            [name in self._hidden for name in self._obj_row], dtype=bool)
        if self._blob_hidden.any():
            mask = np.zeros(self._arrays.t_radius.size, dtype=bool)
            start = self._arrays.n_robots + self._arrays.n_boxes
            mask[start:start + self._blob_hidden.size] = self._blob_hidden
            self._target_hidden = mask
        else:
            self._target_hidden = None
        self._invalidate()

    def _release_if_held(self, name: str) -> None:
        for st in self._robots:
            if st.gripper is not None and st.gripper.holding == name:
                self._release(st)
                st.gripper.state = "open"
                st.gripper.target = "open"

    def _hide(self, name: str) -> None:
        bid = self._ids.objects[name]
        idx = sorted(self._ids.objects).index(name)
        pb.resetBasePositionAndOrientation(bid, (idx * 1.0, 0.0, _HIDDEN_Z_M), (0, 0, 0, 1),
                                           physicsClientId=self._client)
        pb.resetBaseVelocity(bid, (0, 0, 0), (0, 0, 0), physicsClientId=self._client)
        pb.changeDynamics(bid, -1, mass=0.0, physicsClientId=self._client)
        self._hidden.add(name)
        self._update_visibility()

    def _unhide(self, name: str) -> None:
        if name in self._hidden:
            self._hidden.discard(name)
            self._update_visibility()
            pb.changeDynamics(self._ids.objects[name], -1, mass=self._obj_spec(name).mass_kg,
                              physicsClientId=self._client)

    # ---- ptz -------------------------------------------------------------------------------
    def ptz(self, robot: str) -> PtzState:
        st = self._device(robot, "ptz")
        p = st.ptz
        assert p is not None
        return PtzState(p.pan, p.tilt, p.zoom, p.pan_speed, p.tilt_speed)

    def ptz_command(self, robot: str, pan: float, tilt: float, zoom: float) -> None:
        """Targets in radians (zoom = horizontal field of view), clamped to the head's limits;
        the head moves there at its maximum speeds."""
        st = self._device(robot, "ptz")
        spec = st.spec.devices.ptz
        p = st.ptz
        assert spec is not None and p is not None
        for v in (pan, tilt, zoom):
            if not math.isfinite(v):
                raise ValueError("ptz targets must be finite")
        p.pan_target = min(spec.pan_max_rad, max(spec.pan_min_rad, float(pan)))
        p.tilt_target = min(spec.tilt_max_rad, max(spec.tilt_min_rad, float(tilt)))
        p.zoom_target = min(spec.zoom_max_rad, max(spec.zoom_min_rad, float(zoom)))

    def _advance_ptz(self, st: _Robot, dt: float) -> None:
        spec = st.spec.devices.ptz
        p = st.ptz
        assert spec is not None and p is not None
        pan = ramp(p.pan, p.pan_target, spec.pan_speed_radps * dt)
        tilt = ramp(p.tilt, p.tilt_target, spec.tilt_speed_radps * dt)
        p.pan_speed, p.tilt_speed = (pan - p.pan) / dt, (tilt - p.tilt) / dt
        p.pan, p.tilt = pan, tilt
        p.zoom = ramp(p.zoom, p.zoom_target, spec.zoom_speed_radps * dt)

    # ---- power -----------------------------------------------------------------------------
    def power(self, robot: str) -> PowerState:
        st = self._device(robot, "power")
        assert st.battery is not None
        return st.battery.reading()

    def set_battery(self, robot: str, fraction: float) -> None:
        """Set a battery's charge (0..1) directly, e.g. to script a low-battery test."""
        st = self._device(robot, "power")
        assert st.battery is not None
        if not 0.0 <= fraction <= 1.0:
            raise ValueError("fraction must be within [0, 1]")
        b = st.battery
        b.joules = b.spec.capacity_j * fraction
        b.flat = b.fraction <= b.spec.flat_fraction

    def set_charger_enabled(self, charger: str, enabled: bool) -> None:
        """Switch a charging pad off (a robot on it no longer charges) or on again; from the
        next step on, so it acts at a tick boundary."""
        if charger not in {c.name for c in self.spec.chargers}:
            raise KeyError(f"no charger named {charger!r}")
        if enabled:
            self._chargers_off.discard(charger)
        else:
            self._chargers_off.add(charger)

    def charger_enabled(self, charger: str) -> bool:
        return charger not in self._chargers_off

    # ---- fiducials -------------------------------------------------------------------------
    def fiducials(self, robot: str) -> tuple[Fiducial, ...]:
        """Robots and objects with a fiducial id within the detector's range and fan."""
        st = self._device(robot, "fiducial")
        spec = st.spec.devices.fiducial
        assert spec is not None

        def compute() -> tuple[Fiducial, ...]:
            m = spec.pose
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            sx, sy = st.x + c * m.x - s * m.y, st.y + s * m.x + c * m.y
            syaw = st.yaw + m.yaw
            things: list[tuple[int, float, float, float]] = []
            for other in self._robots:
                if other is not st and other.spec.fiducial_id > 0:
                    things.append((other.spec.fiducial_id, other.x, other.y, other.yaw))
            for o in self._obj_specs:
                if o.fiducial_id > 0 and o.name not in self._hidden:
                    things.append((o.fiducial_id, *self._dyn_pose(o.name)))
            out = []
            for fid, x, y, yaw in things:
                wx, wy = x - sx, y - sy
                rng = math.hypot(wx, wy)
                bearing = wrap_angle(math.atan2(wy, wx) - syaw)
                if spec.min_range_m <= rng <= spec.max_range_m and \
                        abs(bearing) <= spec.fov_rad / 2:
                    cs, sn = math.cos(syaw), math.sin(syaw)
                    out.append(Fiducial(fid, cs * wx + sn * wy, -sn * wx + cs * wy,
                                        wrap_angle(yaw - syaw), rng, bearing))
            return tuple(sorted(out, key=lambda f: f.range_m))

        return self._cached(("fiducials", st.index), compute)  # type: ignore[return-value]

    # ---- overhead camera and snapshots -----------------------------------------------------
    def overhead(self) -> tuple[TrackedObject, ...]:
        """Robots, boxes, objects and markers inside the overhead camera's view."""
        oc = self.spec.overhead_camera
        if oc is None:
            raise ValueError(f"world {self.spec.name!r} has no overhead camera")

        def compute() -> tuple[TrackedObject, ...]:
            colours = self._spec_colours()
            noise = None
            if oc.position_noise_m > 0:
                noise = np.random.default_rng([self._noise_seed, self.tick])
            half_x, half_y = oc.view_size_x_m / 2, oc.view_size_y_m / 2
            seen = self._seen
            make = _make_tracked
            out = []
            for bp in self.snapshot().bodies:
                if abs(bp.x - oc.x) > half_x or abs(bp.y - oc.y) > half_y:
                    continue
                if noise is not None:
                    n = noise.standard_normal(2) * oc.position_noise_m
                    out.append(make(bp.name, bp.kind, colours[bp.name], bp.x + float(n[0]),
                                    bp.y + float(n[1]), bp.yaw))
                    continue
                # a body that has not moved keeps its pose object, and its tracked thing
                hit = seen.get(bp.name)
                if hit is None or hit[0] is not bp:
                    hit = seen[bp.name] = (bp, make(bp.name, bp.kind, colours[bp.name], bp.x,
                                                    bp.y, bp.yaw))
                out.append(hit[1])
            return tuple(out)

        return self._cached("overhead", compute)  # type: ignore[return-value]

    def _spec_colours(self) -> dict[str, int]:
        """Name -> colour of every robot, box, object and marker (fixed by the world)."""
        colours = self._colours
        if colours is None:
            colours = {r.name: r.colour for r in self.spec.robots}
            colours.update({b.name: b.colour for b in self.spec.boxes})
            colours.update({o.name: o.colour for o in self.spec.objects})
            colours.update({m.name: m.colour for m in self.spec.markers})
            self._colours = colours
        return colours

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

            bodies = [pose(st.spec.name, "robot", st.x, st.y, st.yaw) for st in self._robots]
            kinds = self._dyn_kinds
            hidden = self._hidden
            for name, kind, (x, y, yaw) in zip(self._dyn_row, kinds,
                                               self._dynamic_poses().tolist(), strict=True):
                if name not in hidden:
                    bodies.append(pose(name, kind, x, y, yaw))
            marker_pos = self._marker_pos
            bodies += [pose(m.name, "marker", *marker_pos[m.name]) for m in self.spec.markers]
            return SceneSnapshot(self.time_s, self.tick, tuple(bodies))

        return self._cached("snapshot", compute)  # type: ignore[return-value]
