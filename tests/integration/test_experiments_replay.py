"""replay.html: size of a multi-hour run, and what headless Chromium actually draws."""

from __future__ import annotations

import colorsys
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from sibling import load_sibling

from experiments import events as ev
from experiments.replay import write_replay
from player_server.viz import scene
from worlds import load_world, world_path

_headless = load_sibling(__file__, "headless.py")

pytestmark = pytest.mark.timeout(600)  # a browser on a loaded machine may take minutes


def _synthetic_run(layout: scene.SceneLayout, duration_s: float, period_s: float = 1.0):
    """Poses of every body every `period_s` (robots circling), and a few state changes."""
    poses = []
    n = int(duration_s / period_s) + 1
    for k in range(n):
        t = k * period_s
        bodies = {}
        for i, r in enumerate(layout.robots):
            a = 0.002 * t + i
            bodies[r.name] = (r.x_m + 0.4 * math.sin(a), r.y_m + 0.4 * math.cos(a), a)
        for b in layout.boxes:
            bodies[b.name] = (b.x_m, b.y_m, b.yaw_rad)  # boxes stand still
        for o in layout.objects:
            bodies[o.name] = (o.x_m, o.y_m, 0.0)
        poses.append({"t": t, "kind": ev.POSES, "bodies": bodies})
    worker, charger = layout.robots[0].name, layout.robots[1].name
    events = [
        ev.make_event(0.0, ev.TASK_INTRODUCED, task="t1", task_kind="sentry-duty"),
        ev.make_event(0.0, ev.AWARD, task="t1", robot=worker),
        ev.make_event(0.0, ev.CHARGE_START, robot=charger),
        ev.make_event(duration_s * 0.9, ev.CHARGE_END, robot=charger),
        ev.make_event(duration_s * 0.95, ev.TASK_OUTCOME, task="t1", outcome=ev.COMPLETED),
    ]
    return poses, events


def test_three_hour_replay_stays_a_few_megabytes(tmp_path: Path) -> None:
    layout = scene.layout_from_world(load_world(world_path("longterm")))
    poses, events = _synthetic_run(layout, 3 * 3600.0)
    info = write_replay(tmp_path / "replay.html", layout, poses, events)
    assert info.bytes < 4_000_000, info
    still = len(layout.boxes) + len(layout.objects)
    assert info.keyframes <= 1500 * len(layout.robots) + 2 * still
    assert info.duration_s == pytest.approx(3 * 3600.0)
    assert 3 * 3600.0 / info.speed <= 120.0 + 1e-6  # plays in two minutes
    html = info.path.read_text(encoding="utf-8")
    assert "MeshCat.Viewer" in html and "<script src=" not in html  # self-contained


def _screenshots(exe: str, jobs: list[tuple[Path, Path]], tmp: Path) -> None:
    """Render each (html, png) pair, in parallel, each with a fresh profile."""
    _headless.screenshots(exe, [(html.resolve().as_uri(), png) for html, png in jobs],
                          _headless.Profiles(tmp))


def _rgb(colour: int) -> np.ndarray:
    return np.array([(colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF])


def _count_exact(img: np.ndarray, colour: int, tol: int = 8) -> int:
    return int((np.abs(img - _rgb(colour)).max(axis=2) <= tol).sum())


def _count_hue(img: np.ndarray, colour: int) -> int:
    """Pixels of the colour's hue, saturated and bright (lit faces vary in brightness; the
    sky-blue background gradient is never both this saturated and this bright)."""
    h0, _, _ = colorsys.rgb_to_hsv(*(_rgb(colour) / 255.0))
    hsv = cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_RGB2HSV_FULL).astype(float)
    hue = hsv[:, :, 0] / 255.0
    dh = np.minimum(np.abs(hue - h0), 1.0 - np.abs(hue - h0))
    return int(((dh < 10 / 360) & (hsv[:, :, 1] >= 0.7 * 255) & (hsv[:, :, 2] >= 0.5 * 255)).sum())


def _load_rgb(png: Path) -> np.ndarray:
    img = cv2.imread(str(png), cv2.IMREAD_COLOR)
    assert img is not None and img.shape[:2] == (768, 1024)
    return img[:, :, ::-1].astype(int)  # BGR -> RGB


@pytest.mark.browser
def test_replay_renders_the_scene_in_headless_chromium(tmp_path: Path) -> None:
    exe = _headless.require_chromium()
    spec = load_world(world_path("longterm"))
    layout = scene.layout_from_world(spec)
    poses, events = _synthetic_run(layout, 1800.0, period_s=5.0)
    busy = write_replay(tmp_path / "busy.html", layout, poses, events)
    quiet = write_replay(tmp_path / "quiet.html", layout, poses, [])  # every robot idle
    _screenshots(exe, [(busy.path, tmp_path / "busy.png"), (quiet.path, tmp_path / "quiet.png")],
                 tmp_path)
    img, base = _load_rgb(tmp_path / "busy.png"), _load_rgb(tmp_path / "quiet.png")
    total = img.shape[0] * img.shape[1]
    # the floor (unlit, exact colour) fills a good part of the view
    assert _count_exact(img, spec.arena.floor_colour) > 0.15 * total
    # charging pads (unlit) are visible
    for charger in spec.chargers:
        assert _count_exact(img, charger.colour, tol=30) > 150, f"charger {charger.name}"
    # robots coloured by state: all idle in one replay; one working and one charging in the
    # other (the world has orange boxes, so compare the two renders)
    idle, working, charging = (scene.STATE_COLOURS[s] for s in
                               (scene.IDLE, scene.WORKING, scene.CHARGING))
    assert _count_hue(base, idle) > 400
    assert _count_hue(img, idle) < _count_hue(base, idle) - 200
    assert _count_hue(img, working) > _count_hue(base, working) + 200
    assert _count_hue(img, charging) > _count_hue(base, charging) + 200


def _crowded_run(layout: scene.SceneLayout, duration_s: float):
    """Every robot driving from its start into a huddle half a metre across by half time,
    a cleanup of an orange box for the first robot, battery levels every 30 s."""
    poses = []
    robots = layout.robots
    for k in range(int(duration_s) + 1):
        t = float(k)
        a = min(1.0, 2.0 * t / duration_s)
        bodies = {}
        for i, r in enumerate(robots):
            hx, hy = 0.25 * math.cos(i), 0.25 * math.sin(i)
            bodies[r.name] = (r.x_m + a * (hx - r.x_m), r.y_m + a * (hy - r.y_m), 0.1 * i)
        poses.append({"t": t, "kind": ev.POSES, "bodies": bodies})
    first = robots[0].name
    events = [
        ev.make_event(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="cleanup",
                      params={"colour": "#ff8000"}),
        ev.make_event(2.0, ev.AWARD, task="t1", robot=first),
        *(ev.make_event(float(t), ev.BATTERY,
                        percent={r.name: 100.0 - t / 30.0 - i for i, r in enumerate(robots)})
          for t in range(0, int(duration_s), 30)),
    ]
    return poses, events


@pytest.mark.browser
@pytest.mark.parametrize("world", ["longterm", "boxpush"])
def test_replay_labels_of_a_huddle_never_overlap_and_links_open_at_their_moment(
        tmp_path: Path, world: str) -> None:
    exe = _headless.require_chromium()
    layout = scene.layout_from_world(load_world(world_path(world)))
    poses, events = _crowded_run(layout, 600.0)
    info = write_replay(tmp_path / "replay.html", layout, poses, events)
    profiles = _headless.Profiles(tmp_path)
    first = layout.robots[0].name
    for t, huddled in ((100, False), (7 * 60 + 40, True)):
        url = f"{info.path.resolve().as_uri()}#t={t // 60}:{t % 60:02d}"
        state = _headless.page_state(exe, url, profiles, budget_ms=1000)
        assert state["t"] == pytest.approx(t, abs=0.05) and state["slider"] == pytest.approx(t)
        assert state["clock"] == f"sim 0:{t // 60:02d}:{t % 60:02d}"
        for name, (x, y, _yaw) in state["robots"].items():
            want = next(p for p in poses if p["t"] == t)["bodies"][name]
            assert math.hypot(x - want[0], y - want[1]) < 0.05, (name, t)
        assert len(state["labels"]) == len(layout.robots)
        assert _headless.overlapping(state["labels"]) == []
        me = state["info"][first]
        assert me["task"] == "cleanup: orange box" and me["colour"] == "#ff8000"
        assert me["marked"] is True  # orange is also the colour of a working robot
        assert me["battery"] == round(100.0 - (t // 30 * 30) / 30.0)
        if huddled:
            spread = max(math.hypot(x, y) for x, y, _ in state["robots"].values())
            assert spread < 0.3
    _headless.screenshots(exe, [(f"{info.path.resolve().as_uri()}#t=7:40",
                                 tmp_path / f"{world}.png")], profiles, size=(1400, 900))
