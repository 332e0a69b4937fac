"""The live meshcat view: a thread that mirrors simulation snapshots into the viewer.

The simulation never waits for the viewer. Its owner hands over the newest snapshot with
`LiveView.offer` (one lock and one assignment; older, unsent snapshots are simply replaced) or
gives the view a `source` callable that the view's own thread polls. Robot states and task
labels arrive through `set_robot`, battery levels through `set_battery`. Besides the bodies,
the scene carries the data of the page's HTML (`hud`): the legend, each robot's label block
(name, battery, task -> target) and the simulation clock of the newest snapshot, sent last in
each frame, after that snapshot's poses. The view's thread wakes at most `max_rate_hz` times
a second, sends only what changed, and keeps running (with back-off) while no viewer answers.
"""

from __future__ import annotations

import logging
import math
import threading
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from player_server.viz import hud, scene
from player_server.viz.server import ViewerUnavailable

log = logging.getLogger(__name__)

Pose = tuple[float, float, float]


class CommandSink(Protocol):
    def send(self, command: dict[str, Any]) -> None: ...


def body_poses(snapshot: Any) -> dict[str, Pose]:
    """Poses by body name from a `SceneSnapshot` (bodies of (name, kind, x, y, yaw) tuples or
    objects with those attributes) or from a plain mapping name -> (x, y, yaw)."""
    if isinstance(snapshot, Mapping):
        return {str(k): (float(v[0]), float(v[1]), float(v[2])) for k, v in snapshot.items()}
    poses: dict[str, Pose] = {}
    for body in snapshot.bodies:
        if isinstance(body, tuple):
            name, _kind, x, y, yaw = body[:5]
        else:
            name, x, y = body.name, body.x, body.y
            yaw = getattr(body, "yaw", getattr(body, "yaw_rad", 0.0))
        poses[str(name)] = (float(x), float(y), float(yaw))
    return poses


@dataclass(frozen=True, slots=True)
class RobotView:
    state: str = scene.IDLE
    label: str = ""
    target_colour: int | None = None
    battery: int | None = None  # percent, rounded: what the label shows


@dataclass(frozen=True, slots=True)
class LiveStats:
    frames: int
    commands: int
    snapshots_offered: int
    snapshots_replaced: int
    viewer_errors: int


class LiveView:
    """Owns one thread; `start()`, then `stop()` (which re-raises the thread's failure)."""

    def __init__(
        self,
        layout: scene.SceneLayout,
        sink: CommandSink,
        *,
        max_rate_hz: float = 10.0,
        source: Callable[[], Any] | None = None,
        move_epsilon_m: float = 0.002,
        retry_period_s: float = 1.0,
        trail_points: int = 0,
        trail_step_m: float = 0.1,
        lasers: bool = False,
    ) -> None:
        """`trail_points` > 0 draws a trail behind each robot: its last that many positions,
        `trail_step_m` apart; `lasers`: the legend explains laser rays."""
        if max_rate_hz <= 0:
            raise ValueError("max_rate_hz must be positive")
        self._layout = layout
        self._sink = sink
        self._period_s = 1.0 / max_rate_hz
        self._source = source
        self._eps = move_epsilon_m
        self._retry_s = retry_period_s
        self._paths = layout.body_paths()
        self._lock = threading.Lock()
        self._latest: Any = None
        self._wanted: dict[str, RobotView] = {}
        self._battery: dict[str, float] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        # state of the viewer as last sent; owned by the view's thread
        self._sent_poses: dict[str, Pose] = {}
        self._sent_robots: dict[str, RobotView] = {}
        self._sent_clock: float | None = None
        self._legend_lasers = lasers
        self._scene_sent = False
        self._ids = scene.IdSource("live")
        self._frames = 0
        self._commands = 0
        self._offered = 0
        self._replaced = 0
        self._viewer_errors = 0
        self._trail_points = max(0, int(trail_points))
        self._trail_step_m = trail_step_m
        self._trails: dict[str, deque[tuple[float, float]]] = {}
        self._trails_changed: set[str] = set()
        self._robot_names = {r.name for r in layout.robots}
        self._lasers = {shape.robot: shape for shape in layout.lasers}
        self._latest_scans: dict[str, Any] = {}

    # --- called by the simulation's owner (any thread) ---

    def offer(self, snapshot: Any) -> None:
        with self._lock:
            if self._latest is not None:
                self._replaced += 1
            self._latest = snapshot
            self._offered += 1

    def set_robot(self, robot: str, state: str, label: str = "",
                  target_colour: int | None = None) -> None:
        """`label`: the task and its target ("cleanup: orange box"); `target_colour`: the
        colour the target is named by."""
        if state not in scene.STATE_COLOURS:
            raise ValueError(f"unknown robot state {state!r}; expected one of {scene.ROBOT_STATES}")
        with self._lock:
            self._wanted[robot] = RobotView(state, label, target_colour)

    def offer_scans(self, scans: Mapping[str, Any]) -> None:
        """The newest laser ranges of some robots (drawn as rays; robots without a laser in
        the layout are ignored). Cheap: one lock and a dict update."""
        with self._lock:
            self._latest_scans.update(scans)

    def set_battery(self, robot: str, percent: float) -> None:
        if not math.isfinite(percent):
            raise ValueError(f"battery of {robot} is not a number: {percent!r}")
        with self._lock:
            self._battery[robot] = float(percent)

    def stats(self) -> LiveStats:
        with self._lock:
            return LiveStats(self._frames, self._commands, self._offered, self._replaced,
                             self._viewer_errors)

    # --- lifecycle ---

    def start(self) -> None:
        if self._thread is not None:
            raise RuntimeError("the live view is already started")
        self._thread = threading.Thread(target=self._run, name="meshcat-live", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                raise RuntimeError("the live view thread did not stop")
        if self._error is not None:
            raise RuntimeError("the live view failed") from self._error

    def __enter__(self) -> LiveView:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- the view's thread ---

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                try:
                    self.publish_once()
                except ViewerUnavailable as exc:
                    with self._lock:
                        self._viewer_errors += 1
                    log.warning("%s; retrying in %.1f s", exc, self._retry_s)
                    self._scene_sent = False  # a restarted viewer needs the whole scene again
                    self._stop.wait(self._retry_s)
                    continue
                self._stop.wait(self._period_s)
        except BaseException as exc:  # the owner sees it in stop()
            log.exception("live view failed")
            self._error = exc

    def publish_once(self) -> int:
        """Send what changed since the last call; returns the number of commands sent."""
        if self._source is not None:
            snap = self._source()
            if snap is not None:
                self.offer(snap)
        with self._lock:
            snap, self._latest = self._latest, None
            wanted = dict(self._wanted)
            battery = dict(self._battery)
            scans, self._latest_scans = self._latest_scans, {}
        commands: list[dict[str, Any]] = []
        if not self._scene_sent:
            commands.extend(scene.static_scene(self._layout, id_prefix="live-scene"))
            commands.append(hud.legend_command(self._ids, self._layout,
                                               trails=self._trail_points > 0,
                                               lasers=self._legend_lasers))
            self._sent_poses.clear()
            self._sent_robots = {r.name: RobotView() for r in self._layout.robots}
            commands.extend(hud.robot_info_command(self._ids, hud.robot_info(r.name))
                            for r in self._layout.robots)
            self._sent_clock = None
        t = getattr(snap, "time_s", None) if snap is not None else None
        if snap is not None:
            commands.extend(self._pose_commands(body_poses(snap)))
        commands.extend(self._robot_commands(wanted, battery))
        for robot, ranges in scans.items():
            shape = self._lasers.get(robot)
            if shape is not None:
                commands.append(scene.laser_command(self._ids, shape, ranges))
        for robot in sorted(self._trails_changed):
            commands.append(scene.trail_command(self._ids, robot, self._trails[robot]))
        self._trails_changed.clear()
        if t is None and self._sent_clock is None:
            t = 0.0
        if t is not None and float(t) != self._sent_clock:
            # last: the page takes the clock as the end of this snapshot's frame
            self._sent_clock = float(t)
            commands.append(hud.clock_command(self._ids, float(t)))
        for cmd in commands:
            self._sink.send(cmd)
        self._scene_sent = True
        with self._lock:
            self._frames += 1
            self._commands += len(commands)
        return len(commands)

    def _pose_commands(self, poses: Mapping[str, Pose]) -> Iterable[dict[str, Any]]:
        for name, (x, y, yaw) in poses.items():
            path = self._paths.get(name)
            if path is None:
                continue
            old = self._sent_poses.get(name)
            if old is not None and (
                math.hypot(x - old[0], y - old[1]) < self._eps
                and abs(math.remainder(yaw - old[2], math.tau)) < self._eps
            ):
                continue
            self._sent_poses[name] = (x, y, yaw)
            if self._trail_points and name in self._robot_names:
                trail = self._trails.setdefault(name, deque(maxlen=self._trail_points))
                if not trail or math.hypot(x - trail[-1][0], y - trail[-1][1]) >= (
                        self._trail_step_m):
                    trail.append((x, y))
                    if len(trail) >= 2:
                        self._trails_changed.add(name)
            yield scene.set_transform(path, scene.pose_matrix(x, y, 0.0, yaw))

    def _robot_commands(self, wanted: Mapping[str, RobotView],
                        battery: Mapping[str, float]) -> Iterable[dict[str, Any]]:
        for robot, old in list(self._sent_robots.items()):
            view = wanted.get(robot, old)
            percent = battery.get(robot)
            shown = round(percent) if percent is not None else old.battery
            new = RobotView(view.state, view.label, view.target_colour, shown)
            if new == old:
                continue
            if new.state != old.state:
                yield from scene.state_change(robot, old.state, new.state)
            self._sent_robots[robot] = new
            yield hud.robot_info_command(self._ids, hud.robot_info(
                robot, new.state, new.battery, new.label, new.target_colour))
