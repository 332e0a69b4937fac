"""The live meshcat viewer process: loopback-only sockets, and the live view feeding it."""

from __future__ import annotations

import base64
import itertools
import os
import re
import threading
import time
from pathlib import Path

import pytest
import umsgpack
import zmq
from sibling import load_sibling

from player_server.viz import scene
from player_server.viz.live import LiveView
from player_server.viz.server import ViewerProcess, ViewerUnavailable, ZmqChannel
from worlds import load_world, world_path

pytestmark = pytest.mark.timeout(600)  # a browser on a loaded machine may take minutes
_headless = load_sibling(__file__, "headless.py")


def _listening_sockets(pid: int) -> list[tuple[str, str, int]]:
    """(family, local address hex, port) of every listening TCP socket owned by `pid`."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        m = re.match(r"socket:\[(\d+)\]", target)
        if m:
            inodes.add(m.group(1))
    found = []
    for family in ("tcp", "tcp6"):
        lines = Path(f"/proc/net/{family}").read_text().splitlines()[1:]
        for line in lines:
            cols = line.split()
            local, state, inode = cols[1], cols[3], cols[9]
            if state == "0A" and inode in inodes:  # 0A = LISTEN
                addr, port_hex = local.split(":")
                found.append((family, addr, int(port_hex, 16)))
    return found


def _port(url: str) -> int:
    m = re.search(r":(\d+)(/|$)", url.split("//", 1)[1])
    assert m, url
    return int(m.group(1))


def test_viewer_listens_on_loopback_only() -> None:
    with ViewerProcess() as viewer:
        assert viewer.urls.web_url.startswith("http://127.0.0.1:")
        assert viewer.urls.zmq_url.startswith("tcp://127.0.0.1:")
        web_port, zmq_port = _port(viewer.urls.web_url), _port(viewer.urls.zmq_url)
        sockets = _listening_sockets(viewer.pid)
        ports = {port for _, _, port in sockets}
        assert {web_port, zmq_port} <= ports, sockets
        for family, addr, port in sockets:
            # 0100007F is 127.0.0.1 in /proc/net/tcp's little-endian hex
            assert (family, addr) == ("tcp", "0100007F"), f"port {port} listens on {family} {addr}"


def test_stock_meshcat_would_listen_everywhere() -> None:
    """The reason for our own bridge: stock meshcat's tornado listen() has no address."""
    import inspect
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from meshcat.servers import zmqserver

    source = inspect.getsource(zmqserver.ZMQWebSocketBridge.__init__)
    assert "self.app.listen(port, **listen_kwargs)" in source


def _scene_commands(zmq_url: str) -> list[dict]:
    """Ask the viewer for its scene (meshcat's get_scene) and decode the embedded commands."""
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.RCVTIMEO, 5000)
    sock.setsockopt(zmq.LINGER, 0)
    try:
        sock.connect(zmq_url)
        sock.send(b"get_scene")
        html = sock.recv().decode("utf-8")
    finally:
        sock.close()
        ctx.term()
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def test_live_view_mirrors_snapshots_and_states() -> None:
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    robot = layout.robots[0].name
    box = layout.boxes[0].name
    with ViewerProcess() as viewer:
        channel = ZmqChannel(viewer.urls.zmq_url, timeout_s=5.0)
        view = LiveView(layout, channel, max_rate_hz=50.0)
        try:
            view.start()
            view.offer({robot: (1.25, -0.5, 0.3), box: (2.0, 2.0, 0.0)})
            view.set_robot(robot, scene.WORKING, "sentry-duty t7")
            deadline = time.monotonic() + 10.0
            while view.stats().frames < 3 and time.monotonic() < deadline:
                time.sleep(0.05)
            view.offer({robot: (1.5, -0.5, 0.3)})
            target = view.stats().frames + 2
            while view.stats().frames < target and time.monotonic() < deadline:
                time.sleep(0.05)
        finally:
            view.stop()
            channel.close()
        assert view.stats().viewer_errors == 0
        cmds = _scene_commands(viewer.urls.zmq_url)
    rpath = scene.robot_path(robot)
    transforms = {c["path"]: c["matrix"] for c in cmds if c["type"] == "set_transform"}
    assert transforms[rpath][12:14] == pytest.approx([1.5, -0.5], abs=1e-3)
    assert transforms[f"{scene.ROOT}/boxes/{box}"][12:14] == pytest.approx([2.0, 2.0], abs=1e-3)
    visible = {
        c["path"]: c["value"]
        for c in cmds
        if c["type"] == "set_property" and c["property"] == "visible"
    }
    assert visible[f"{rpath}/body/working"] is True
    assert visible[f"{rpath}/body/idle"] is False
    infos = [c for c in cmds if c["type"] == "set_object" and c["path"] == f"{rpath}/info"]
    assert infos and infos[-1]["object"]["object"]["userData"]["task"] == "sentry-duty t7"


def test_live_view_never_blocks_the_offering_thread_and_survives_a_dead_viewer() -> None:
    layout = scene.layout_from_world(load_world(world_path("simple")))
    robot = layout.robots[0].name
    viewer = ViewerProcess()
    channel = ZmqChannel(viewer.urls.zmq_url, timeout_s=0.3)
    view = LiveView(layout, channel, max_rate_hz=20.0, retry_period_s=0.1)
    view.start()
    try:
        viewer.stop()  # the viewer goes away under the view
        offered = 0
        t0 = time.monotonic()
        for i in range(20000):  # a fast simulation loop
            view.offer({robot: (0.001 * i, 0.0, 0.0)})
            offered += 1
        elapsed = time.monotonic() - t0
        deadline = time.monotonic() + 20.0
        while view.stats().viewer_errors < 1 and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        view.stop()
        channel.close()
    stats = view.stats()
    assert stats.snapshots_offered == offered
    assert elapsed < 2.0  # offering is a lock and an assignment, never a network wait
    assert stats.viewer_errors >= 1
    assert threading.active_count() < 50


def test_channel_refuses_remote_addresses() -> None:
    with pytest.raises(ValueError, match="off this host"):
        ZmqChannel("tcp://10.0.0.1:6000")


def test_channel_times_out_without_a_viewer() -> None:
    ctx = zmq.Context()
    # a bound REP socket that never answers
    rep = ctx.socket(zmq.REP)
    rep.setsockopt(zmq.LINGER, 0)
    port = rep.bind_to_random_port("tcp://127.0.0.1")
    channel = ZmqChannel(f"tcp://127.0.0.1:{port}", timeout_s=0.2)
    try:
        t0 = time.monotonic()
        with pytest.raises(ViewerUnavailable):
            channel.send(scene.delete("/murdoch"))
        assert time.monotonic() - t0 < 2.0
    finally:
        channel.close()
        rep.close()
        ctx.term()


def test_live_scene_tree_has_legend_labels_and_clock() -> None:
    """What the viewer holds (meshcat's own scene tree, as any browser would load it)."""
    layout = scene.layout_from_world(load_world(world_path("longterm")))

    class Snap:
        time_s = 754.0
        bodies = ()

    with ViewerProcess() as viewer:
        channel = ZmqChannel(viewer.urls.zmq_url, timeout_s=5.0)
        view = LiveView(layout, channel, max_rate_hz=50.0)
        try:
            view.start()
            view.offer(Snap())
            view.set_battery("p2", 64.0)
            view.set_robot("p2", scene.WORKING, "cleanup: red box")
            deadline = time.monotonic() + 20.0
            while view.stats().frames < 3 and time.monotonic() < deadline:
                time.sleep(0.05)
        finally:
            view.stop()
            channel.close()
        cmds = _scene_commands(viewer.urls.zmq_url)
    data = {c["path"]: c["object"]["object"]["userData"] for c in cmds
            if c["type"] == "set_object" and c["object"]["object"].get("userData")}
    assert data[f"{scene.ROOT}/hud/clock"]["text"] == "sim 0:12:34"
    legend = [e["label"] for e in data[f"{scene.ROOT}/hud/legend"]["entries"]]
    assert legend[:4] == ["robot idle", "robot working", "robot charging", "robot down"]
    infos = {r.name: data[f"{scene.robot_path(r.name)}/info"] for r in layout.robots}
    assert infos["p2"]["battery"] == 64 and infos["p1"]["battery"] is None
    assert infos["p2"]["task"] == "cleanup: red box"


@pytest.mark.browser
def test_live_view_in_headless_chromium_shows_the_legend(tmp_path: Path) -> None:
    """A real browser on the live view's page: the screenshot shows every state colour (the
    legend's swatches; no robot is charging or down) and is kept next to the test's files."""
    import cv2
    import numpy as np

    exe = _headless.require_chromium()
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    png = tmp_path / "live.png"
    with ViewerProcess() as viewer:
        channel = ZmqChannel(viewer.urls.zmq_url, timeout_s=5.0)
        view = LiveView(layout, channel, max_rate_hz=20.0, trail_points=50)
        try:
            view.start()
            view.set_robot("p2", scene.WORKING, "cleanup: red box")
            for k in range(30):  # p1 drives east: a trail behind it
                view.offer({"p1": (-4.0 + 0.25 * k, 2.0, 0.0)})
                target = view.stats().frames + 1
                deadline = time.monotonic() + 20.0
                while view.stats().frames < target and time.monotonic() < deadline:
                    time.sleep(0.01)
            deadline = time.monotonic() + 20.0
            while view.stats().frames < 3 and time.monotonic() < deadline:
                time.sleep(0.05)
            _headless.screenshots(exe, [(viewer.urls.web_url, png)],
                                  _headless.Profiles(tmp_path), budget_ms=5000)
        finally:
            view.stop()
            channel.close()
    img = cv2.imread(str(png), cv2.IMREAD_COLOR)
    assert img is not None
    rgb = img[:, :, ::-1].astype(int)
    for state, colour in scene.STATE_COLOURS.items():
        want = np.array([(colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF])
        count = int((np.abs(rgb - want).max(axis=2) <= 8).sum())
        assert count > 20, f"no {state} colour in the live view's screenshot"
    trail = np.array([(scene.TRAIL_COLOUR >> 16) & 0xFF, (scene.TRAIL_COLOUR >> 8) & 0xFF,
                      scene.TRAIL_COLOUR & 0xFF])
    assert int((np.abs(rgb - trail).max(axis=2) <= 12).sum()) > 20, "no trail drawn"


@pytest.mark.browser
def test_label_layout_keeps_crowded_labels_apart(tmp_path: Path) -> None:
    """The overlay's pure layout step, run in the browser: forty robots within a few pixels
    of each other, and a row of them, get labels that overlap neither each other nor (where
    there is room) any robot; moments in links parse as simulated seconds."""
    import json

    from player_server.viz.page import OVERLAY_JS

    crowd = [{"id": f"p{i}", "x": 600 + (i % 7) * 6, "y": 400 + (i // 7) * 5,
              "width": 100 + (i % 3) * 30, "height": 22 + (i % 2) * 15} for i in range(40)]
    row = [{"id": f"r{i}", "x": 100 + i * 40, "y": 700, "width": 110, "height": 37}
           for i in range(12)]
    page = tmp_path / "layout.html"
    page.write_text(
        "<!DOCTYPE html><html><body><pre id=\"murdoch-state\"></pre>"
        f"<script src=\"{OVERLAY_JS.resolve().as_uri()}\"></script><script>"
        "var M = MurdochOverlay;"
        "document.getElementById('murdoch-state').textContent = JSON.stringify({"
        f"crowd: M.placeLabels({json.dumps(crowd)}), row: M.placeLabels({json.dumps(row)}),"
        "moments: ['7:40', '1:07:40', '460.5', 'soon', ''].map(M.parseMoment)});"
        "</script></body></html>", encoding="utf-8")
    exe = _headless.require_chromium()
    state = _headless.page_state(exe, page.as_uri(), _headless.Profiles(tmp_path),
                                 budget_ms=200)
    assert state["moments"] == [460, 4060, 460.5, None, None]
    for items, placed in ((crowd, state["crowd"]), (row, state["row"])):
        rects = {it["id"]: (placed[it["id"]]["left"], placed[it["id"]]["top"], it["width"],
                            it["height"]) for it in items}
        assert len(rects) == len(items)
        assert _headless.overlapping(rects) == []
    # in the row there is room: no label covers a robot, and each stays near its own
    for it in row:
        left, top = state["row"][it["id"]]["left"], state["row"][it["id"]]["top"]
        for other in row:
            assert not (left < other["x"] < left + it["width"]
                        and top < other["y"] < top + it["height"]), (it["id"], other["id"])
        assert abs(left + it["width"] / 2 - it["x"]) < 200 and abs(top - it["y"]) < 150


@pytest.fixture(scope="module")
def live_run(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A real ten-minute `murdoch run longterm --meshcat`, with the live view's page state
    read by headless Chromium every few seconds while it runs; then its run directory
    (run.mcap, replay.html). The run is paced by the wall clock at a speed-up chosen from how
    long this machine's Chromium takes to read a page (up to 15x real time, idle), and the
    page is sent frames at the default rate (`--live-rate`) at that top pace, fewer at a
    slower one (a browser that cannot keep up with its feed never finishes a read). A machine
    loaded by more than that read showed may still keep the page from being read during the
    run: the run is then made again, eight times slower (down to 1.5x real time) and with
    the page fed once a second, as a user of a slow machine would."""
    exe = _headless.require_chromium()
    tmp = tmp_path_factory.mktemp("live-run")
    profiles = _headless.Profiles(tmp)
    speedup = _pace_for_reads(exe, profiles, run_s=600.0, reads=5)
    live_rate = _live_rate_for(speedup)
    for attempt in itertools.count():
        watched = _watch_run(exe, tmp / f"run{attempt}", profiles, speedup, live_rate)
        times = [s["t"] for s in _drawn(watched["states"])]
        if (len(times) >= 3 and times[-1] - times[0] > 120.0) or (
                speedup <= MIN_PACE and live_rate == SLOW_LIVE_RATE):
            return watched
        speedup, live_rate = max(MIN_PACE, speedup / 8.0), SLOW_LIVE_RATE
    raise AssertionError("unreachable")


MIN_PACE, MAX_PACE = 1.5, 15.0
"""The slowest and fastest pace of the watched run: ten simulated minutes in under seven, and
in forty seconds."""
SLOW_LIVE_RATE = 1.0
"""The fewest frames a second the page is sent (in the second, slower watched run)."""


def _live_rate_for(speedup: float) -> float | None:
    """The page's frames a second at a pace: the default (None) at MAX_PACE, fewer in
    proportion below it, down to SLOW_LIVE_RATE."""
    from experiments.run_checks import LIVE_RATE_HZ

    if speedup >= MAX_PACE:
        return None
    return max(SLOW_LIVE_RATE, round(LIVE_RATE_HZ * speedup / MAX_PACE, 1))


READ_TIMEOUT_S = 150.0
"""The longest one read of the page during the run may take; one that takes longer is
missed (the run goes on, and the next read starts)."""


def _drawn(states: list[dict]) -> list[dict]:
    """The page states read while the run was drawn: a clock and robots on the page."""
    return [s for s in states if s["t"] is not None and s["robots"]]


def _watch_run(exe: str, tmp: Path, profiles: object, speedup: float,
               live_rate: float | None) -> dict:
    """`murdoch run longterm --until 10m --meshcat` at `speedup` (and `--live-rate`, when
    given), its page read while it runs, then once more (and a screenshot) while its last
    frame is held."""
    import queue
    import signal
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "murdoch", "run", "longterm", "--until", "10m", "--meshcat",
         "--speedup", f"{speedup:.2f}", "--seed", "1", "--out", str(tmp / "runs"),
         *(["--live-rate", f"{live_rate:g}"] if live_rate is not None else [])],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True)
    lines: queue.Queue[str] = queue.Queue()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.put(line)

    threading.Thread(target=read, daemon=True).start()
    seen: list[str] = []

    def wait_for(text: str, timeout_s: float) -> str:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                line = lines.get(timeout=max(0.01, deadline - time.monotonic()))
            except queue.Empty:
                break
            seen.append(line)
            if text in line:
                return line
        raise AssertionError(f"no {text!r} from murdoch run; it said:\n{''.join(seen[-30:])}")

    states: list[dict] = []
    try:
        root = Path(wait_for("run directory:", 120).split(":", 1)[1].strip())
        url = wait_for("meshcat live view:", 120).split(": ", 1)[1].strip()
        deadline = time.monotonic() + 500
        for _ in range(40):  # the page's state every few seconds until the run ends
            left = deadline - time.monotonic()
            if proc.poll() is not None or left <= 0:
                break
            try:
                state = _headless.page_state(exe, url, profiles, budget_ms=1500,
                                             nice=READ_NICE,
                                             timeout_s=min(left, READ_TIMEOUT_S))
            except subprocess.TimeoutExpired:
                continue  # missed; the run goes on
            states.append(state)
            if state["t"] is not None and state["t"] >= 599.0:
                break
        wait_for("the live view stays up", 500)  # finished: run.mcap and replay.html written
        # the last frame, held: its page state and a screenshot of it
        final = _headless.page_state(exe, url, profiles, budget_ms=1500, nice=READ_NICE)
        # a screenshot whose viewport is the one the state was read in (headless Chromium's
        # --dump-dom page is shorter than its --window-size)
        width, height = final["view"]
        _headless.screenshots(exe, [(url, tmp / "live.png")], profiles, size=(width, height),
                              budget_ms=SHOT_BUDGET_MS, nice=READ_NICE, timeout_s=120.0,
                              attempts=2)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)  # closes the held view
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    return {"root": root, "states": states, "profiles": profiles, "exe": exe, "final": final,
            "png": tmp / "live.png", "speedup": speedup}


SHOT_BUDGET_MS = 5000
"""Virtual time before the held view's screenshot is taken. On one CPU shared with busy loops
a screenshot after 1.5 s of it never came (the browser idle, three times in three), as if
it waited for a frame that virtual time had already passed; after 5 s it takes 8 s."""
READ_NICE = -10
"""The browser reading the live view asks for a higher priority than the run's ten processes
(where it may: as root), so that on a loaded machine the run, not the reads it is watched by,
falls behind; and so that its software-rendered screenshot of the held view is not starved."""


def _pace_for_reads(exe: str, profiles: object, *, run_s: float, reads: int) -> float:
    """A speed-up (simulated seconds per wall second) at which a run of `run_s` simulated
    seconds lasts long enough for `reads` reads of its live view, each counted as twice one
    read of the same page timed here on a viewer of the same world (during the run the
    browser shares the machine with it): between MIN_PACE and MAX_PACE."""
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    with ViewerProcess() as viewer:
        channel = ZmqChannel(viewer.urls.zmq_url, timeout_s=5.0)
        view = LiveView(layout, channel, max_rate_hz=20.0)
        try:
            view.start()
            view.offer({r.name: (0.5 * i, 0.0, 0.0) for i, r in enumerate(layout.robots)})
            deadline = time.monotonic() + 60.0
            while view.stats().frames < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            start = time.monotonic()
            state = _headless.page_state(exe, viewer.urls.web_url, profiles, budget_ms=1500,
                                         nice=READ_NICE)
            read_s = 2.0 * (time.monotonic() - start)
        finally:
            view.stop()
            channel.close()
    assert state["mode"] == "live", state
    return max(MIN_PACE, min(MAX_PACE, run_s / (reads * read_s)))


def _recorded(root: Path) -> list[dict]:
    from experiments.report import recorded_poses

    return list(recorded_poses(root / "run.mcap"))


def _assert_matches_recording(state: dict, frames: list[dict], tolerance_m: float) -> None:
    import math

    for robot, (x, y, _yaw) in state["robots"].items():
        rx, ry = _headless.pose_at(frames, state["t"], robot)
        assert math.hypot(x - rx, y - ry) < tolerance_m, (
            f"{robot} drawn at ({x:.2f}, {y:.2f}) at {state['clock']}; "
            f"the recording has ({rx:.2f}, {ry:.2f})")


@pytest.mark.browser
@pytest.mark.timeout(900)
def test_live_view_follows_a_real_run_in_headless_chromium(live_run: dict) -> None:
    """The page of `murdoch run --meshcat` at several simulated times: its clock runs with the
    run, every robot is drawn where run.mcap has it at that time (so every robot that drives
    moves), and no robot's label overlaps another's."""
    import math

    states = _drawn(live_run["states"])
    assert len(states) >= 2, (live_run["speedup"], live_run["states"])
    frames = _recorded(live_run["root"])
    times = [s["t"] for s in states]
    assert times == sorted(times) and times[-1] - times[0] > 120.0, times
    moved = set()
    for a, b in itertools.pairwise(states):
        for robot in a["robots"]:
            (xa, ya), (xb, yb) = (_headless.pose_at(frames, s["t"], robot) for s in (a, b))
            if math.hypot(xb - xa, yb - ya) > 0.3:  # it drove: the view shows it moving
                pa, pb = a["robots"][robot], b["robots"][robot]
                assert math.hypot(pb[0] - pa[0], pb[1] - pa[1]) > 0.2, (robot, a["t"], b["t"])
                moved.add(robot)
    assert moved, "no robot drove in the run"
    for s in states:
        assert s["clock"] == scene_clock(s["t"])
        _assert_matches_recording(s, frames, 0.12)
        assert set(s["labels"]) == set(s["robots"])
        assert _headless.overlapping(s["labels"]) == [], s["clock"]
        if s["t"] > 0:  # the feed runs with the simulation: battery levels from the first step
            assert all(info["battery"] is not None for info in s["info"].values()), s["info"]


@pytest.mark.browser
@pytest.mark.timeout(900)
def test_live_labels_point_at_their_robots_in_the_screenshot(live_run: dict) -> None:
    """Each label's leader line ends on its robot as the browser drew it: around the anchor
    the page reports, the screenshot shows the colour of that robot's state."""
    import colorsys

    import cv2
    import numpy as np

    state = live_run["final"]
    img = cv2.imread(str(live_run["png"]), cv2.IMREAD_COLOR)
    assert img is not None and img.shape[:2] == (state["view"][1], state["view"][0])
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV_FULL).astype(float)
    assert set(state["anchors"]) == set(state["robots"])
    for robot, (x, y) in state["anchors"].items():
        colour = state["info"][robot]["stateColour"]
        h0 = colorsys.rgb_to_hsv(*(int(colour[i:i + 2], 16) / 255.0 for i in (1, 3, 5)))[0]
        win = hsv[max(0, int(y) - 8):int(y) + 9, max(0, int(x) - 8):int(x) + 9]
        dh = np.abs(win[:, :, 0] / 255.0 - h0)
        dh = np.minimum(dh, 1.0 - dh)
        hits = int(((dh < 12 / 360) & (win[:, :, 1] > 0.4 * 255)).sum())
        assert hits >= 20, f"{robot}'s label points at ({x:.0f}, {y:.0f}), not at the robot"


@pytest.mark.browser
@pytest.mark.timeout(900)
def test_replay_of_the_run_at_two_slider_positions(live_run: dict) -> None:
    """replay.html of the same run, opened at two moments (``#t=m:ss``, which moves the
    slider): clock, slider and scene agree with run.mcap at that simulated time."""
    frames = _recorded(live_run["root"])
    replay = live_run["root"] / "replay.html"
    for t in (95, 7 * 60 + 40):
        url = f"{replay.as_uri()}#t={t // 60}:{t % 60:02d}"
        state = _headless.page_state(live_run["exe"], url, live_run["profiles"], budget_ms=1500)
        assert state["t"] == pytest.approx(t, abs=0.05) and state["slider"] == pytest.approx(t)
        assert state["clock"] == scene_clock(t) and state["playing"] is False
        _assert_matches_recording(state, frames, 0.1)
        assert _headless.overlapping(state["labels"]) == []
        assert all(info["battery"] is not None for info in state["info"].values())


def scene_clock(t: float) -> str:
    from player_server.viz.hud import clock_text

    return clock_text(t)
