"""A recorded run over the real simulation: run directory, live view, report and replay."""

from __future__ import annotations

import io
import json
import time
from datetime import datetime
from pathlib import Path

import pytest

from experiments import events as ev
from experiments.recorder import RunRecorder, parse_proc_status, read_process_memory
from experiments.report import recorded_poses
from player_server.sim import Simulation
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(120)


def test_parse_proc_status() -> None:
    text = "Name:\tpython\nVmHWM:\t  20480 kB\nVmRSS:\t  10240 kB\n"
    assert parse_proc_status(text) == {"rss_bytes": 10240 * 1024, "peak_rss_bytes": 20480 * 1024}
    import os

    mem = read_process_memory(os.getpid())
    assert mem is not None and 0 < mem["rss_bytes"] <= mem["peak_rss_bytes"]
    assert read_process_memory(2**22 + 12345) is None


def test_an_exited_process_not_yet_reaped_has_no_memory_sample() -> None:
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        status = Path(f"/proc/{proc.pid}/status")
        deadline = time.monotonic() + 30
        while "State:\tZ" not in status.read_text() and time.monotonic() < deadline:
            time.sleep(0.02)  # exited, not reaped: a zombie whose status lists no memory
        assert "State:\tZ" in status.read_text()
        assert read_process_memory(proc.pid) is None
    finally:
        proc.wait()


def test_recorded_run_with_live_view(tmp_path: Path) -> None:
    spec = load_world(world_path("simple"))
    robot = spec.robots[0].name
    out = io.StringIO()
    wall = time.monotonic
    rec = RunRecorder(
        tmp_path / "runs", "simple", {"seed": 5, "world": "simple"}, world=spec,
        started=datetime(2026, 5, 6, 7, 8, 9), wall_clock=wall, stream=out, terminal=False,
        meshcat=True, progress_period_sim_s=20.0, live_rate_hz=50.0,
    )
    sim = Simulation(spec, seed=5)
    try:
        observed = rec.observe(sim)  # as the runner does: wrapped before the view exists
        rec.start()
        assert rec.viewer_url is not None and rec.viewer_url.startswith("http://127.0.0.1:")
        rec.event(sim.time_s, ev.TASK_INTRODUCED, task="t1", task_kind="goto-goal")
        rec.event(sim.time_s, ev.AWARD, task="t1", robot=robot, latency_s=0.2)
        sim.set_velocity(robot, 0.3, 0.2)
        for _ in range(600):  # 60 simulated seconds
            observed.step()
            rec.advance(observed.time_s)
            rec.tick()
        rec.event(sim.time_s, ev.TASK_OUTCOME, task="t1", robot=robot, outcome=ev.COMPLETED)
        rec.sample_processes(sim.time_s, {"runner": __import__("os").getpid()})
        deadline = time.monotonic() + 20
        while rec.live.stats().frames < 5 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert rec.live.stats().viewer_errors == 0
        final = sim.get_pose(robot)
        report = rec.finish("completed")
    finally:
        sim.close()
    run = report.run
    assert f"meshcat live view: {rec.viewer_url}" in out.getvalue()
    lines = [ln for ln in out.getvalue().splitlines() if ln.startswith("sim ")]
    assert len(lines) >= 3  # one per 20 simulated seconds and a final one
    config = json.loads(run.config.read_text())
    assert config == {"experiment": "simple", "seed": 5, "world": "simple", "record": True,
                      "record_rate_hz": 2.0}
    poses = list(recorded_poses(run.recording))  # two samples per simulated second
    assert 119 <= len(poses) <= 121
    last = poses[-1]["bodies"][robot]
    assert last[:2] == pytest.approx(list(final[:2]), abs=0.05)
    kinds = [e["kind"] for e in ev.read_events(run.events)]
    assert kinds[0] == ev.RUN_START and kinds[-1] == ev.RUN_END
    s = report.summary
    assert s["tasks"]["executed"] == 1 and s["invariant_terminal_states"]["holds"]
    assert s["sim_time_s"] == pytest.approx(60.0, abs=0.2)
    assert s["real_time_factor"] > 1.0
    assert s["processes"]["runner"]["peak_rss_bytes"] > 0
    assert report.replay is not None and report.replay.stat().st_size > 800_000
    for name in ("tasks.png", "battery.png", "allocation.png"):
        assert (run.plots / name).is_file()
    with pytest.raises(RuntimeError, match="already finished"):
        rec.finish("completed")


def test_the_live_view_can_stay_up_after_the_run_until_ctrl_c(tmp_path: Path) -> None:
    spec = load_world(world_path("simple"))
    out = io.StringIO()
    rec = RunRecorder(
        tmp_path / "runs", "simple", {"seed": 5, "world": "simple", "duration_s": 60.0},
        world=spec, started=datetime(2026, 5, 6, 7, 8, 9), wall_clock=time.monotonic,
        stream=out, terminal=False, meshcat=True,
    )
    rec.start()
    viewer = rec._viewer
    rec.finish("completed", replay=False, keep_viewer=True)
    assert viewer.alive()  # the last frame stays on screen
    waited = []

    def ctrl_c() -> None:
        waited.append(viewer.alive())
        raise KeyboardInterrupt

    rec.hold_viewer(ctrl_c)
    assert waited == [True]
    assert not viewer.alive()
    assert f"the live view stays up at {rec.viewer_url}; press Ctrl-C to close it" in out.getvalue()


def test_the_live_view_shows_laser_rays_and_trails_when_asked(tmp_path: Path) -> None:
    from sibling import load_sibling

    from player_server.viz import scene

    scene_commands = load_sibling(__file__, "test_viz_live.py")._scene_commands
    spec = load_world(world_path("simple"))
    robot = spec.robots[0].name
    rec = RunRecorder(
        tmp_path / "runs", "simple", {"seed": 5, "world": "simple"}, world=spec,
        started=datetime(2026, 5, 6, 7, 8, 9), wall_clock=time.monotonic, stream=io.StringIO(),
        terminal=False, meshcat=True, live_rate_hz=50.0, live_trail_points=100,
        live_lasers=True,
    )
    sim = Simulation(spec, seed=5)
    try:
        observed = rec.observe(sim)  # as the runner does: wrapped before the view exists
        rec.start()
        sim.set_velocity(robot, 0.4, 0.0)
        deadline = time.monotonic() + 60
        while sim.get_pose(robot)[0] < 0.6 and time.monotonic() < deadline:
            observed.step()
        time.sleep(0.05)  # the next step hands over a snapshot (the live period has passed)
        observed.step()
        target = rec.live.stats().frames + 3  # ... and the view has sent it
        # the view keeps only the latest snapshot: it may have seen none of the first
        # stretch, so the robot drives on (a trail point every 0.1 m) with each step seen
        while ((rec.live.stats().frames < target or sim.get_pose(robot)[0] < 1.0)
               and time.monotonic() < deadline):
            time.sleep(0.03)  # past the live period: each step hands over a snapshot
            observed.step()
        viewer_url = rec._viewer.urls.zmq_url
        rec.live.stop()  # the view's last frame is in the viewer; read it back
        cmds = scene_commands(viewer_url)
        rec.live = None  # already stopped
        rec.finish("completed", replay=False)
    finally:
        sim.close()
    paths = {c["path"]: c for c in cmds if c["type"] == "set_object"}
    laser = paths[f"{scene.robot_path(robot)}/laser"]["object"]
    verts = laser["geometries"][0]["data"]["attributes"]["position"]["array"]
    assert len(verts) == 6 * scene.LASER_RAYS
    assert f"{scene.ROOT}/trails/{robot}" in paths
