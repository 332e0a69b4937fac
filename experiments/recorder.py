"""Everything a run leaves behind and shows while it runs, behind one object.

The experiment runner creates a `RunRecorder`, calls `start()`, reports what happens with
`event(...)`, wraps its simulation with `observe(sim)` (the recording's sensor and pose samples
and the live view), samples process memory with `sample_processes(...)` now and then, calls
`tick()` from its main loop for the progress display, and `finish(reason)` at the end, which
closes ``run.mcap`` and writes the summary, plots and replay (built from ``run.mcap``). With
`meshcat=True` the live viewer is started and its URL printed; with `record=False` there is
no ``run.mcap`` and so no replay.
"""

from __future__ import annotations

import logging
import math
import os
import re
import threading
from collections.abc import Callable, Mapping
from datetime import datetime
from pathlib import Path
from typing import Any, TextIO

from experiments import events as ev
from experiments import rundir as rd
from experiments.observe import ObservedSim, SnapshotSim
from experiments.progress import Progress, ProgressDisplay, ProgressTracker
from experiments.recording import RunRecording
from experiments.report import Report, build_report
from experiments.run_checks import LIVE_RATE_HZ
from experiments.timeline import RobotStateTracker

log = logging.getLogger(__name__)

_STATUS_RE = re.compile(r"^(VmRSS|VmHWM):\s+(\d+)\s+kB", re.MULTILINE)


def parse_proc_status(text: str) -> dict[str, int]:
    """Resident and peak resident memory in bytes from /proc/<pid>/status."""
    values = {k: int(v) * 1024 for k, v in _STATUS_RE.findall(text)}
    return {"rss_bytes": values.get("VmRSS", 0), "peak_rss_bytes": values.get("VmHWM", 0)}


def read_process_cpu_s(pid: int) -> float | None:
    """CPU seconds (user + system) the process has used so far; None when it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        ticks = int(fields[11]) + int(fields[12])  # utime, stime (fields 14 and 15)
    except (OSError, IndexError, ValueError):
        return None
    return ticks / os.sysconf("SC_CLK_TCK")


def read_process_memory(pid: int) -> dict[str, int] | None:
    """None when the process is gone or exiting (its status then lists no memory)."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    return parse_proc_status(text) if "VmRSS:" in text else None


def _duration_of(config: Mapping[str, Any]) -> float | None:
    value = config.get("duration_s")
    return float(value) if isinstance(value, int | float) and value > 0 else None


class RunRecorder:
    def __init__(
        self,
        out: Path,
        experiment: str,
        config: Mapping[str, Any],
        *,
        world: Any,
        started: datetime,
        wall_clock: Callable[[], float],
        stream: TextIO,
        terminal: bool | None = None,
        meshcat: bool = False,
        record: bool = True,
        record_rate_hz: float = 2.0,
        progress_period_sim_s: float = 300.0,
        live_rate_hz: float = LIVE_RATE_HZ,
        live_trail_points: int = 0,
        live_lasers: bool = False,
    ) -> None:
        self.world = world
        self.experiment = experiment
        self.config = dict(config)
        self.run = rd.create_run_dir(out, experiment, started)
        self._clock = wall_clock
        self._t0 = wall_clock()
        self._stream = stream
        self._events = ev.EventWriter(self.run.events, clock=wall_clock)
        self._processes = ev.EventWriter(self.run.processes, clock=wall_clock)
        if record and not (record_rate_hz > 0 and math.isfinite(record_rate_hz)):
            raise ValueError(f"the record rate must be a positive number of Hz, got "
                             f"{record_rate_hz}")
        self._record = record
        self._record_rate_hz = float(record_rate_hz)
        self.recording: RunRecording | None = None
        robots = tuple(r.name for r in world.robots)
        self.tracker = ProgressTracker(robots)
        self._states = RobotStateTracker()
        for r in robots:
            self._states.add_robot(r)
        self.display = ProgressDisplay(
            self.tracker, wall_clock=wall_clock, stream=stream, terminal=terminal,
            line_period_sim_s=progress_period_sim_s, title=f"murdoch {experiment}",
            duration_s=_duration_of(config),
        )
        self._meshcat = meshcat
        self._live_rate_hz = live_rate_hz
        self._live_trail_points = live_trail_points
        self._live_lasers = live_lasers
        self._viewer: Any = None
        self._channel: Any = None
        self.live: Any = None
        self._feed: Any = None
        self.viewer_url: str | None = None
        self._finished = False
        self._lock = threading.Lock()

    # --- lifecycle ---

    def start(self) -> None:
        self.run.write_config({"experiment": self.experiment, **self.config,
                               "record": self._record,
                               "record_rate_hz": self._record_rate_hz if self._record else None})
        if self._record:
            # its writer process starts here, after the runner has chosen its CPUs
            self.recording = RunRecording(self.run.recording, self.world,
                                          rate_hz=self._record_rate_hz)
        self.event(0.0, ev.RUN_START, experiment=self.experiment,
                   seed=self.config.get("seed"), world=str(self.config.get("world", "")))
        if self._meshcat:
            self._start_viewer()
        self.display.start()

    def _start_viewer(self) -> None:
        from player_server.viz.feed import LiveFeed
        from player_server.viz.live import LiveView
        from player_server.viz.scene import layout_from_world
        from player_server.viz.server import ViewerProcess, ZmqChannel

        self._viewer = ViewerProcess()
        self._channel = ZmqChannel(self._viewer.urls.zmq_url)
        self.live = LiveView(layout_from_world(self.world), self._channel,
                             max_rate_hz=self._live_rate_hz,
                             trail_points=self._live_trail_points,
                             lasers=self._live_lasers)
        lasers = tuple(r.name for r in self.world.robots
                       if r.mobile and r.devices.laser is not None)
        self._feed = LiveFeed(
            self.live, wall_clock=self._clock, period_s=1.0 / self._live_rate_hz,
            power_robots=tuple(r.name for r in self.world.robots
                               if r.devices.power is not None),
            scan_robots=lasers if self._live_lasers else ())
        self.live.start()
        self.viewer_url = self._viewer.urls.web_url
        self._stream.write(f"meshcat live view: {self.viewer_url}\n")
        self._stream.flush()

    def _feed_live(self, sim: Any) -> None:
        # bound late: the runner wraps its simulation before `start()` makes the view
        feed = self._feed
        if feed is not None:
            feed.after_step(sim)

    def observe(
        self, sim: SnapshotSim, *, battery_period_s: float = 30.0,
        samplers: tuple[tuple[float, Callable[[Any, float], None]], ...] = (),
    ) -> ObservedSim:
        """Wrap the simulation for the serving loop: the recording's samples (every
        1 / record rate simulated seconds, once `start()` has opened it), the live view, and a
        battery event of every robot with a power device every `battery_period_s`; `samplers`
        (period in simulation seconds, callback(sim, t)) also run on the serving thread."""
        powered = tuple(r.name for r in self.world.robots if r.devices.power is not None)

        def sample_battery(s: Any, t: float) -> None:
            if powered:
                self.event(t, ev.BATTERY,
                           percent={r: round(float(s.power(r).percent), 2) for r in powered})

        def sample_recording(s: Any, t: float) -> None:
            if self.recording is not None:
                self.recording.on_step(s, t)

        record = ((0.0, sample_recording),) if self._record else ()
        return ObservedSim(
            sim, samplers=((battery_period_s, sample_battery), *samplers, *record),
            live=self._feed_live if self._meshcat else None,
        )

    # --- while running ---

    def event(self, t: float, kind: str, **fields: Any) -> dict[str, Any]:
        """Record one event (any thread)."""
        e = self._events.write(t, kind, **fields)
        self.tracker.apply(e)
        with self._lock:
            changed = self._states.apply(e)
            live = self.live
            if live is not None:
                for robot, state in changed.items():
                    live.set_robot(robot, state.state, state.view_label, state.target_colour)
            recording = self.recording
            if recording is not None:
                recording.event(e)
                if changed:
                    recording.robot_states(
                        t, {r: (st.state, st.label) for r, st in changed.items()},
                        {r: (st.state, st.label) for r, st in self._states.states().items()})
        return e

    def robot_states(self) -> dict[str, str]:
        """Each robot's state now: idle, working, charging or failed."""
        with self._lock:
            return {name: st.state for name, st in self._states.states().items()}

    def advance(self, sim_s: float) -> None:
        self.tracker.advance(sim_s)

    def note_process(self, t: float, what: str, robot: str, pid: int | None,
                     **fields: Any) -> None:
        """A robot process started, killed or exited (pids are facts of this machine, not
        of the run's history: processes.jsonl)."""
        self._processes.write(t, ev.PROCESS_NOTE, what=what, robot=robot, pid=pid,
                              wall_s=round(self.wall_s(), 3), **fields)

    def sample_processes(self, t: float, pids: Mapping[str, int],
                         robots: Mapping[str, int] | None = None) -> None:
        """Memory and CPU time so far of each process, into processes.jsonl (wall-clock
        facts, not events); `robots`: how many robots a process runs, for those that run
        more than one."""
        for name, pid in pids.items():
            mem = read_process_memory(pid)
            if mem is not None:
                cpu = read_process_cpu_s(pid)
                extra: dict[str, Any] = {"cpu_s": round(cpu, 3)} if cpu is not None else {}
                if robots and name in robots:
                    extra["robots"] = robots[name]
                self._processes.write(t, ev.PROCESS, name=name, pid=pid,
                                      wall_s=round(self.wall_s(), 3), **mem, **extra)

    def tick(self) -> None:
        self.display.tick()

    def wall_s(self) -> float:
        return self._clock() - self._t0

    def progress(self) -> Progress:
        return self.display.snapshot()

    def finish(self, reason: str, *, replay: bool = True, plots: bool = True,
               end_t: float | None = None,
               extra: Mapping[str, Any] | None = None, keep_viewer: bool = False) -> Report:
        """Write run_end, close the logs, stop the viewer (unless `keep_viewer`: then
        `hold_viewer` or `close_viewer` later), build summary, plots (unless not `plots`)
        and replay.

        `extra`: wall-clock facts of the run kept beside the wall time in processes.jsonl."""
        if self._finished:
            raise RuntimeError("the run is already finished")
        self._finished = True
        t = self.tracker.progress(0.0).sim_s if end_t is None else end_t
        try:
            self.event(t, ev.RUN_END, reason=reason)
            self._processes.write(t, ev.RUN_WALL, wall_s=round(self.wall_s(), 3),
                                  **dict(extra or {}))
        finally:
            self._events.close()
            self._processes.close()
            self.display.stop()
            if not keep_viewer:
                self._stop_viewer()
            if self.recording is not None:
                self.recording.close()
        distance = (self.recording.distance()
                    if self.recording is not None and self.recording.complete else None)
        return build_report(self.run, replay=replay and self._record, plots=plots,
                            distance=distance)

    def hold_viewer(self, wait: Callable[[], None]) -> None:
        """Keep the live view up after the run (its last frame stays on screen) until `wait`
        returns or raises KeyboardInterrupt (Ctrl-C), then stop it. `wait` is
        `signal.pause` in the command; tests pass their own."""
        if self.live is None:
            return
        self._stream.write(f"the live view stays up at {self.viewer_url}; "
                           "press Ctrl-C to close it\n")
        self._stream.flush()
        try:
            wait()
        except KeyboardInterrupt:
            pass
        finally:
            self._stop_viewer()

    def close_viewer(self) -> None:
        self._stop_viewer()

    def _stop_viewer(self) -> None:
        errors: list[BaseException] = []
        for stop in (
            self.live.stop if self.live is not None else None,
            self._channel.close if self._channel is not None else None,
            self._viewer.stop if self._viewer is not None else None,
        ):
            if stop is None:
                continue
            try:
                stop()
            except Exception as exc:  # keep stopping the rest; report below
                errors.append(exc)
        with self._lock:
            self.live = self._channel = self._viewer = self._feed = None
        if errors:
            log.error("stopping the live view: %s", errors[0])
