"""`RunRecording`: the run as it goes, into ``run.mcap`` (the channels of
`player_server.record.channels`).

Three inputs, one file:

- `on_step(sim, t)` runs on the serving thread after every step (a sampler of `ObservedSim`)
  and calls `sample(sim, t)` at every tick on a multiple of 1 / `rate_hz` simulated seconds:
  it copies what the simulation holds now - every body's pose, each robot's laser and sonar
  ranges, odometry, battery and blobs - and hands it to the writer process
  (`player_server.record.writer`), which builds and encodes the messages. The sensing
  kernels have already computed this tick's readings for the robots' own Player rounds, so
  sampling reads caches.
- `event(e)` records a run event (as the Log line it is in events.jsonl).
- `robot_states(t, states)` records the robots' states when one changes.

Nothing here writes to events.jsonl or decides anything in the run: recording or not, a
lockstep run's events are the same.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from experiments import events as ev
from experiments.driven import PathLengths
from experiments.observe import snapshot_poses
from player_server.record import channels as ch
from player_server.record.writer import McapSink
from player_server.viz import scene
from worlds.polygon import prism_mesh

DEFAULT_RATE_HZ = 2.0
_WARNING_KINDS = frozenset({ev.ROBOT_FAILURE, ev.FAULT_SKIPPED, ev.REALLOCATION, ev.ALARM,
                            ev.GOAL_UNACHIEVABLE})
_STATE_CODES = {scene.IDLE: 0, scene.WORKING: 1, scene.CHARGING: 2, scene.FAILED: 3}


class _Sensing(NamedTuple):
    """What is sampled of one robot (fixed by the world; a tuple, so that it travels to the
    writer process with every sample cheaply)."""

    name: str
    odometry: bool
    laser: tuple[float, float, float, float, float, float] | None  # mount, min, max angle
    sonar: tuple[tuple[tuple[float, float, float], ...], float] | None  # mounts, max range
    power: bool
    blobs: tuple[int, int] | None  # image width, height


def _mount(m: Any) -> list[float]:
    return [float(m.x), float(m.y), float(m.z), float(m.yaw)]


def world_info(world: Any, rate_hz: float) -> dict[str, Any]:
    """Each robot's devices as the Player replay needs them (geometry, scan layout)."""
    robots: dict[str, Any] = {}
    for r in world.robots:
        d = r.devices
        dev: dict[str, Any] = {}
        if d.position2d is not None:
            dev["position2d"] = {"max_speed": float(d.position2d.max_speed_mps)}
        if d.laser is not None:
            s = d.laser
            dev["laser"] = {"pose": _mount(s.pose), "min_angle": s.min_angle_rad,
                            "max_angle": s.max_angle_rad, "samples": s.samples,
                            "resolution": s.resolution_rad, "max_range": s.max_range_m,
                            "range_res": s.range_res_m, "frequency": s.frequency_hz}
        if d.sonar is not None:
            dev["sonar"] = {"poses": [_mount(m) for m in d.sonar.poses],
                            "max_range": float(d.sonar.max_range_m)}
        if d.power is not None:
            dev["power"] = {}
        if d.blobfinder is not None and d.camera is not None:
            dev["blobfinder"] = {"width": int(d.camera.width_px),
                                 "height": int(d.camera.height_px)}
        robots[r.name] = {
            "mobile": bool(r.mobile),
            "body": {"length": float(r.body.length_m), "width": float(r.body.width_m),
                     "height": float(r.body.height_m), "offset_x": float(r.body.offset_x_m)},
            "devices": dev,
        }
    return {"world": str(world.name), "interval_s": float(world.sim.interval_sim_s),
            "record_rate_hz": rate_hz, "robots": robots}


def _sensing(world: Any) -> tuple[_Sensing, ...]:
    out = []
    for r in world.robots:
        d = r.devices
        laser = sonar = blobs = None
        if d.laser is not None:
            p = d.laser.pose
            laser = (float(p.x), float(p.y), float(p.z), float(p.yaw),
                     float(d.laser.min_angle_rad), float(d.laser.max_angle_rad))
        if d.sonar is not None:
            sonar = (tuple((float(m.x), float(m.y), float(m.yaw)) for m in d.sonar.poses),
                     float(d.sonar.max_range_m))
        if d.blobfinder is not None and d.camera is not None:
            blobs = (int(d.camera.width_px), int(d.camera.height_px))
        out.append(_Sensing(r.name, d.position2d is not None, laser, sonar,
                            d.power is not None, blobs))
    return tuple(out)


def static_scene(layout: scene.SceneLayout) -> dict[str, Any]:
    """The world that never moves, in the world frame."""
    ents = []
    w, h = layout.x_max_m - layout.x_min_m, layout.y_max_m - layout.y_min_m
    cx, cy = layout.centre
    ents.append(ch.entity(0.0, ch.WORLD_FRAME, "floor", cubes=[
        ch.cube(cx, cy, -0.005, 0.0, w, h, 0.01, layout.floor_colour)]))
    for kind, blocks in (("wall", layout.walls), ("obstacle", layout.obstacles)):
        for b in blocks:
            ents.append(ch.entity(0.0, ch.WORLD_FRAME, f"{kind}/{b.name}", cubes=[
                ch.cube(b.x_m, b.y_m, b.size_z_m / 2, b.yaw_rad, b.size_x_m, b.size_y_m,
                        b.size_z_m, b.colour)]))
    for p in layout.prisms:
        verts, tris = prism_mesh(p.points, p.bottom_m, p.top_m)
        ents.append(ch.entity(0.0, ch.WORLD_FRAME, f"obstacle/{p.name}",
                              triangle_lists=[ch.triangles(verts, tris, p.colour)]))
    for kind, discs in (("post", layout.posts), ("charger", layout.chargers)):
        for d in discs:
            ents.append(ch.entity(0.0, ch.WORLD_FRAME, f"{kind}/{d.name}", cylinders=[
                ch.cylinder(d.x_m, d.y_m, d.height_m / 2, d.radius_m, d.height_m, d.colour)],
                texts=[ch.text(d.x_m, d.y_m, d.height_m + 0.2, d.name)]
                if kind == "charger" else []))
    return ch.scene_update(ents)


def bodies_scene(layout: scene.SceneLayout) -> dict[str, Any]:
    """Boxes, objects and markers, each drawn in its own frame (posed by /tf)."""
    ents = []
    for b in layout.boxes:
        ents.append(ch.entity(0.0, b.name, f"box/{b.name}", frame_locked=True, cubes=[
            ch.cube(0.0, 0.0, b.size_z_m / 2, 0.0, b.size_x_m, b.size_y_m, b.size_z_m,
                    b.colour)]))
    for kind, discs in (("object", layout.objects), ("marker", layout.markers)):
        for d in discs:
            ents.append(ch.entity(0.0, d.name, f"{kind}/{d.name}", frame_locked=True,
                                  cylinders=[ch.cylinder(0.0, 0.0, d.height_m / 2, d.radius_m,
                                                         d.height_m, d.colour)],
                                  texts=[ch.text(0.0, 0.0, d.height_m + 0.2, d.name)]
                                  if kind == "marker" else []))
    return ch.scene_update(ents)


def robots_scene(t: float, layout: scene.SceneLayout,
                 states: Mapping[str, tuple[str, str]]) -> dict[str, Any]:
    """Every robot's body in its state's colour, a heading marker and its task label."""
    ents = []
    height = scene.ROBOT_HEIGHT_M
    for r in layout.robots:
        state, label = states.get(r.name, (scene.IDLE, ""))
        words = r.name if not label else f"{r.name}: {label}"
        colour = scene.STATE_COLOURS.get(state, scene.STATE_COLOURS[scene.IDLE])
        nose = ch.cube(r.offset_x_m + r.length_m / 2 - 0.05, 0.0, height + 0.01, 0.0, 0.1, 0.1,
                       0.02, scene.NOSE_COLOUR)
        texts = [ch.text(0.0, 0.0, scene.LABEL_HEIGHT_M, words)]
        if r.outline:  # the outline's prism, about the body centre
            verts, tris = prism_mesh([(x + r.offset_x_m, y) for x, y in r.outline], 0.0, height)
            ents.append(ch.entity(t, r.name, f"robot/{r.name}", frame_locked=True,
                                  cubes=[nose], texts=texts,
                                  triangle_lists=[ch.triangles(verts, tris, colour)]))
            continue
        ents.append(ch.entity(t, r.name, f"robot/{r.name}", frame_locked=True, cubes=[
            ch.cube(r.offset_x_m, 0.0, height / 2, 0.0, r.length_m, r.width_m, height, colour),
            nose], texts=texts))
    return ch.scene_update(ents)


def _ranges(values: Any, digits: int = 3) -> list[float]:
    """Non-negative finite ranges rounded to millimetres (unusable readings become 0)."""
    a = np.asarray(values, dtype=np.float64)
    a = np.where(np.isfinite(a) & (a >= 0.0), a, 0.0)
    return np.round(a, digits).tolist()


def _odometry(t: float, odometry: tuple[Any, ...]) -> dict[str, Any]:
    """`odometry`: x, y, yaw, vx, vy, vyaw, stall, then the drive command's v and w."""
    x, y, yaw, vx, vy, vyaw, stall, cmd_v, cmd_w = odometry
    return {"timestamp": ch.stamp(t), "x": round(x, 4), "y": round(y, 4),
            "yaw": round(yaw, 4), "vx": round(vx, 4), "vy": round(vy, 4),
            "vyaw": round(vyaw, 4), "stall": stall, "cmd_vx": round(cmd_v, 4),
            "cmd_vyaw": round(cmd_w, 4)}


def _laser(t: float, name: str, mount: tuple[float, float, float, float], lo: float,
           hi: float, ranges: Any) -> dict[str, Any]:
    return ch.laser_scan(t, name, mount, lo, hi, _ranges(ranges))


def _sonar_ranges(t: float, ranges: Any) -> dict[str, Any]:
    return {"timestamp": ch.stamp(t), "ranges": _ranges(ranges)}


def _sonar_scan(t: float, name: str, mounts: Any, max_range: float,
                ranges: Any) -> dict[str, Any]:
    return ch.sonar_ring_scan(t, name, mounts, _ranges(ranges), max_range)


def _battery(t: float, power: tuple[Any, ...]) -> dict[str, Any]:
    """`power`: percent, charging, volts, watts, joules."""
    percent, charging, volts, watts, joules = power
    return {"timestamp": ch.stamp(t), "percent": round(percent, 3),
            "charging": 1 if charging else 0, "volts": round(volts, 3),
            "watts": round(watts, 3), "joules": round(joules, 1)}


def _event_log(t: float, name: str, e: Mapping[str, Any], level: int) -> dict[str, Any]:
    return ch.log_message(t, name, ev.encode_event(e), level)


def _robot_state(t: float, state: str, label: str) -> dict[str, Any]:
    return {"timestamp": ch.stamp(t), "state": state, "label": label,
            "code": _STATE_CODES.get(state, -1)}


class DrivenFromTf:
    """(in the writer process) The metres driven, summed from each /tf as it is recorded:
    the same poses `murdoch report` would read back."""

    def __init__(self, robots: Iterable[str]) -> None:
        self.lengths = PathLengths(robots)

    def written(self, topic: str, t_s: float, body: Mapping[str, Any]) -> None:
        if topic == ch.TF:
            self.lengths.add(ch.poses_of(body))


def _blobs(t: float, width: int, height: int, blobs: Any) -> dict[str, Any]:
    """`blobs`: each blob's id, colour, area, x, y, l, r, t, b and range."""
    seen = [[*b[:9], round(b[9], 3)] for b in blobs]
    return {"timestamp": ch.stamp(t), "width": width, "height": height, "blobs": seen}


_Ranges = tuple[str, bytes]  # an array's dtype and bytes


def _ranges_bytes(values: Any) -> _Ranges:
    a = np.ascontiguousarray(values)
    return a.dtype.str, a.tobytes()


def _ranges_array(wire: _Ranges) -> Any:
    return np.frombuffer(wire[1], dtype=np.dtype(wire[0]))


def _reading(sim: Any, s: _Sensing) -> tuple[Any, ...]:
    """(serving thread) One robot's readings of this tick, as plain numbers and bytes:
    (odometry and drive command, laser, sonar, power, blobs), None where it has none."""
    name = s.name
    odometry = laser = sonar = power = blobs = None
    if s.odometry:
        o = sim.odometry(name)
        v, w = sim.drive_command(name)
        odometry = (float(o.x), float(o.y), float(o.yaw), float(o.vx), float(o.vy),
                    float(o.vyaw), bool(o.stall), float(v), float(w))
    if s.laser is not None:
        laser = _ranges_bytes(sim.laser(name))
    if s.sonar is not None:
        sonar = _ranges_bytes(sim.sonar(name))
    if s.power:
        p = sim.power(name)
        power = (float(p.percent), bool(p.charging), float(p.volts), float(p.watts),
                 float(p.joules))
    if s.blobs is not None:
        blobs = tuple((int(b.id), int(b.colour), int(b.area), int(b.x), int(b.y), int(b.l),
                       int(b.r), int(b.t), int(b.b), float(b.range_m))
                      for b in sim.blobs(name))
    return odometry, laser, sonar, power, blobs


def _sample_messages(t: float, poses: Mapping[str, Any], sensing: tuple[_Sensing, ...],
                     readings: tuple[tuple[Any, ...], ...]) -> list[tuple[str, float, Any]]:
    """(writer process) The messages of one sample, in the order they are written: /tf,
    then each robot's odometry, laser, sonar ranges, sonar scan, battery and blobs (those it
    has), each built when written."""
    items: list[tuple[str, float, Any]] = [(ch.TF, t, partial(ch.frame_transforms, t, poses))]
    topic = ch.robot_topic
    for s, (odo, laser_r, sonar_r, power, seen) in zip(sensing, readings, strict=True):
        name = s.name
        if odo is not None:
            items.append((topic(name, ch.ODOMETRY), t, partial(_odometry, t, odo)))
        if s.laser is not None:
            mx, my, mz, myaw, lo, hi = s.laser
            items.append((topic(name, ch.LASER), t,
                          partial(_laser, t, name, (mx, my, mz, myaw), lo, hi,
                                  _ranges_array(laser_r))))
        if s.sonar is not None:
            mounts, max_range = s.sonar
            ranges = _ranges_array(sonar_r)
            items.append((topic(name, ch.SONAR_RANGES), t, partial(_sonar_ranges, t, ranges)))
            items.append((topic(name, ch.SONAR), t,
                          partial(_sonar_scan, t, name, mounts, max_range, ranges)))
        if power is not None:
            items.append((topic(name, ch.BATTERY), t, partial(_battery, t, power)))
        if s.blobs is not None:
            width, height = s.blobs
            items.append((topic(name, ch.BLOBS), t, partial(_blobs, t, width, height, seen)))
    return items


class RunRecording:
    """Owns ``run.mcap`` of one run (see the module's doc)."""

    def __init__(self, path: Path, world: Any, *, rate_hz: float = DEFAULT_RATE_HZ) -> None:
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise ValueError(f"the record rate must be a positive number of Hz, got {rate_hz}")
        self.path = Path(path)
        self.rate_hz = float(rate_hz)
        self.world = world
        self.layout = scene.layout_from_world(world)
        self._sensing = _sensing(world)
        self._interval = float(world.sim.interval_sim_s)
        self._every = max(1, round(self.period_s / self._interval))
        self._last_tick = -1
        self._sink = McapSink(self.path, observer=DrivenFromTf(
            r.name for r in world.robots if r.mobile))
        self.samples = 0
        self._sink.put(ch.WORLD_INFO, 0.0, world_info(world, self.rate_hz))
        self._sink.put(ch.WORLD_SCENE, 0.0, static_scene(self.layout))
        self._sink.put(ch.BODIES_SCENE, 0.0, bodies_scene(self.layout))
        self._sink.put(ch.ROBOTS_SCENE, 0.0, robots_scene(0.0, self.layout, {}))

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz

    # --- serving thread ---

    def on_step(self, sim: Any, t: float) -> None:
        """After every step: sample at every tick that is a whole multiple of the period (so
        samples are evenly spaced on simulation time and fall on the same ticks in every
        run of the same options)."""
        tick = round(t / self._interval)
        if tick % self._every == 0 and tick != self._last_tick:
            self._last_tick = tick
            self.sample(sim, t)

    def sample(self, sim: Any, t: float) -> None:
        """Take the readings of this tick: copied here as plain numbers and bytes (what the
        next step would change), handed over as one sample, and made into messages and
        encoded in the writer process (`_sample_messages`)."""
        poses = snapshot_poses(sim.snapshot())
        readings = tuple(_reading(sim, s) for s in self._sensing)
        self._sink.put_group(t, partial(_sample_messages, t, poses, self._sensing, readings))
        self.samples += 1

    # --- any thread ---

    def event(self, e: Mapping[str, Any]) -> None:
        kind = str(e["kind"])
        t = float(e["t"])
        level = (ch.LOG_WARNING if kind in _WARNING_KINDS
                 or (kind == ev.TASK_OUTCOME and e.get("outcome") != ev.COMPLETED)
                 else ch.LOG_ERROR if kind == ev.RUN_END and e.get("reason") != "completed"
                 else ch.LOG_INFO)
        name = str(e.get("msg_kind", kind)) if kind == ev.MESSAGE else kind
        self._sink.put(ch.MURDOCH if kind == ev.MESSAGE else ch.EVENTS, t,
                       partial(_event_log, t, name, e, level))

    def robot_states(self, t: float, changed: Mapping[str, tuple[str, str]],
                     every: Mapping[str, tuple[str, str]]) -> None:
        """`changed` robots' states (state, label), then the scene of `every` robot."""
        batch: list[tuple[str, float, Any]] = [
            (ch.robot_topic(robot, ch.STATE), t, partial(_robot_state, t, state, label))
            for robot, (state, label) in changed.items()]
        batch.append((ch.ROBOTS_SCENE, t, partial(robots_scene, t, self.layout, dict(every))))
        self._sink.put_many(batch)

    @property
    def complete(self) -> bool:
        """Everything handed over is in the file (the disk never failed it)."""
        return self._sink.error is None

    def distance(self) -> dict[str, Any]:
        """summary.json's `distance_m` from the poses recorded (known once `close()` has
        returned: the writer process's count comes back with it)."""
        driven = self._sink.observer
        assert isinstance(driven, DrivenFromTf)
        return driven.lengths.summary()

    def close(self) -> None:
        self._sink.close()

    @property
    def written(self) -> int:
        return self._sink.written
