"""``replay.html``: an offline meshcat animation of a run that opens in a browser without a server.

The file holds meshcat's viewer script, the static scene of the world, one animation (the
pose keyframes of every body, from the ``/tf`` channel of ``run.mcap``, the run's one
recording, and the state of every robot: one coloured body per state, shown in turn) and the
page around it (`player_server.viz.page`): each robot's label block (name, battery, task ->
target) from the run's events, the simulation clock, the legend, a slider in simulated time
and links to a moment (``replay.html#t=7:40``). Keyframes are
decimated: a body that stands still keeps only the samples around its moves, and no body keeps
more than `max_keys_per_body`, so a multi-hour run gives a file of a few megabytes. Playback
runs `speed` times faster than simulation time (chosen so that the whole run plays in at most
`max_playback_s`, two minutes by default); the slider and the play button pause and scrub, the
viewer's Animations panel changes the rate.
"""

from __future__ import annotations

import base64
import importlib.util
import itertools
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import umsgpack

from experiments import events as ev
from experiments import timeline
from experiments.rundir import write_text_atomic
from player_server.viz import hud, page, scene

Key = tuple[float, float, float, float]  # t_s, x_m, y_m, yaw_rad

def _viewer_js_path() -> Path:
    """meshcat's bundled viewer script (found without importing meshcat's server modules)."""
    found = importlib.util.find_spec("meshcat")
    if found is None or found.origin is None:
        raise RuntimeError("meshcat is not installed")
    return Path(found.origin).parent / "viewer" / "dist" / "main.min.js"


@dataclass(frozen=True, slots=True)
class ReplayInfo:
    path: Path
    bytes: int
    keyframes: int
    bodies: int
    duration_s: float
    speed: float


def decimate(keys: list[Key], *, max_keys: int, move_eps_m: float = 0.01,
             turn_eps_rad: float = 0.02) -> list[Key]:
    """Keep the first and last key, every key that moved from the last kept one, and the
    key just before a move (so that a body does not drift through a stop); then thin evenly
    to at most `max_keys`."""
    if max_keys < 2:
        raise ValueError("max_keys must be at least 2")
    if len(keys) <= 2:
        return list(keys)
    kept: list[Key] = [keys[0]]
    for prev, key in itertools.pairwise(keys):
        last = kept[-1]
        moved = (math.hypot(key[1] - last[1], key[2] - last[2]) >= move_eps_m
                 or abs(math.remainder(key[3] - last[3], math.tau)) >= turn_eps_rad)
        if moved:
            if prev is not last and prev[0] > last[0]:
                kept.append(prev)
            kept.append(key)
    if kept[-1] is not keys[-1]:
        kept.append(keys[-1])
    if len(kept) > max_keys:
        step = (len(kept) - 1) / (max_keys - 1)
        kept = [kept[round(i * step)] for i in range(max_keys)]
    return kept


def _pose_tracks(keys: list[Key], speed: float, end_play_s: float) -> list[dict[str, Any]]:
    times: list[float] = []
    positions: list[float] = []
    quats: list[float] = []
    prev_q: list[float] | None = None
    for t, x, y, yaw in keys:
        q = scene.yaw_quaternion_xyzw(yaw)
        if prev_q is not None and sum(a * b for a, b in zip(q, prev_q, strict=True)) < 0:
            q = [-c for c in q]  # keep interpolation on the short arc
        prev_q = q
        times.append(round(t / speed, 4))
        positions += [x, y, 0.0]
        quats += q
    if times[-1] < end_play_s:
        times.append(end_play_s)
        positions += positions[-3:]
        quats += quats[-4:]
    return [
        {"name": ".position", "type": "vector3", "times": times, "values": positions},
        {"name": ".quaternion", "type": "quaternion", "times": times, "values": quats},
    ]


def _visible_track(changes: list[tuple[float, bool]], end_play_s: float) -> dict[str, Any]:
    times = [t for t, _ in changes]
    values = [v for _, v in changes]
    if times[-1] < end_play_s:
        times.append(end_play_s)
        values.append(values[-1])
    return {"name": ".visible", "type": "bool", "times": times, "values": values}


def _clip(path: str, tracks: list[dict[str, Any]]) -> dict[str, Any]:
    return {"path": path, "clip": {"fps": 1.0, "name": "default", "tracks": tracks}}


def build_replay_commands(
    layout: scene.SceneLayout,
    pose_events: Iterable[Mapping[str, Any]],
    events: Iterable[Mapping[str, Any]],
    *,
    max_keys_per_body: int = 1500,
    max_playback_s: float = 120.0,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The meshcat commands of the replay and facts about it (keyframes, duration, speed)."""
    paths = layout.body_paths()
    raw: dict[str, list[Key]] = defaultdict(list)
    end_s = 0.0
    for pe in pose_events:
        t = float(pe["t"])
        end_s = max(end_s, t)
        for name, pose in pe["bodies"].items():
            if name in paths:
                raw[name].append((t, float(pose[0]), float(pose[1]), float(pose[2])))
    evs = [e for e in events if e["kind"] != ev.POSES]
    end_s = max([end_s, *(float(e["t"]) for e in evs)])
    speed = max(1.0, end_s / max_playback_s)
    end_play = round(end_s / speed, 4) if end_s > 0 else 1.0

    commands = scene.static_scene(layout, id_prefix="replay")
    clips: list[dict[str, Any]] = []
    total_keys = 0
    for name in sorted(raw):
        keys = sorted(raw[name])
        kept = decimate(keys, max_keys=max_keys_per_body)
        total_keys += len(kept)
        clips.append(_clip(paths[name], _pose_tracks(kept, speed, end_play)))

    robots = [r.name for r in layout.robots]
    intervals = timeline.robot_intervals(evs, robots, end_s=end_s)
    for robot in robots:
        ivs = intervals.get(robot, [])
        for state in scene.ROBOT_STATES:
            changes: list[tuple[float, bool]] = [(0.0, state == scene.IDLE)]
            for iv in ivs:
                changes.append((round(iv.start_s / speed, 4), iv.state == state))
            clips.append(_clip(f"{scene.robot_path(robot)}/body/{state}",
                               [_visible_track(_dedupe(changes), end_play)]))
    ids = scene.IdSource("replay-hud")
    commands.append(hud.legend_command(ids, layout))
    commands.extend(hud.robot_info_command(ids, hud.robot_info(r)) for r in robots)
    labels = label_timeline(evs, robots)
    commands.append(
        {
            "type": "set_animation",
            "path": "",
            "animations": clips,
            "options": {"play": True, "repetitions": 1},
        }
    )
    info = {"keyframes": total_keys, "bodies": len(raw), "duration_s": end_s, "speed": speed,
            "labels": sum(len(v) for v in labels.values()), "timeline": labels}
    return commands, info


def label_timeline(events: Iterable[Mapping[str, Any]], robots: Iterable[str]
                   ) -> dict[str, list[list[Any]]]:
    """Each robot's label block over the run, as changes the page looks up by simulated time:
    [t_s, state, state colour, battery %, "task: target", target colour, marked]."""
    tracker = timeline.RobotStateTracker()
    battery: dict[str, int | None] = {}
    out: dict[str, list[list[Any]]] = {}
    for name in robots:
        tracker.add_robot(name)
        battery[name] = None
        out[name] = []

    def note(t: float, name: str) -> None:
        st = tracker.state_of(name)
        d = hud.robot_info(name, st.state, battery.get(name), st.view_label, st.target_colour)
        row = [round(t, 3), d["state"], d["stateColour"], d["battery"], d["task"], d["colour"],
               d["marked"]]
        rows = out.setdefault(name, [])
        if rows and rows[-1][1:] == row[1:]:
            return
        if rows and rows[-1][0] == row[0]:
            rows[-1] = row
        else:
            rows.append(row)

    for e in events:
        t = float(e["t"])
        if e["kind"] == ev.BATTERY:
            for name, percent in dict(e.get("percent") or {}).items():
                if name in out:
                    battery[name] = round(float(percent))
                    note(t, name)
            continue
        for name in tracker.apply(e):
            if name in out:
                note(t, name)
    return out


def _dedupe(changes: list[tuple[float, bool]]) -> list[tuple[float, bool]]:
    """Last value wins at equal times; drop repeats of the same value."""
    by_time: dict[float, bool] = {}
    for t, v in changes:
        by_time[t] = v
    out: list[tuple[float, bool]] = []
    for t in sorted(by_time):
        if not out or out[-1][1] != by_time[t]:
            out.append((t, by_time[t]))
    return out


def render_html(commands: list[dict[str, Any]], *, title: str, speed: float,
                duration_s: float = 0.0,
                labels: Mapping[str, list[list[Any]]] | None = None) -> str:
    """The self-contained page: meshcat's viewer, the commands, and the overlay (labels,
    clock, legend, a slider in simulated time, ``#t=7:40`` links)."""
    encoded = [
        base64.b64encode(umsgpack.packb(c, force_float_precision="single")).decode("ascii")
        for c in commands
    ]
    viewer_js = _viewer_js_path().read_text(encoding="utf-8")
    replay = {"speed": speed, "duration": duration_s, "timeline": dict(labels or {})}
    return page.page_html(title=title, viewer_script=f"<script>\n{viewer_js}\n</script>",
                          body_script=page.replay_body_script(encoded, replay))


def write_replay(
    out: Path,
    layout: scene.SceneLayout,
    pose_events: Iterable[Mapping[str, Any]],
    events: Iterable[Mapping[str, Any]],
    *,
    title: str = "murdoch replay",
    max_keys_per_body: int = 1500,
    max_playback_s: float = 120.0,
) -> ReplayInfo:
    commands, info = build_replay_commands(
        layout, pose_events, events,
        max_keys_per_body=max_keys_per_body, max_playback_s=max_playback_s,
    )
    html = render_html(commands, title=title, speed=info["speed"],
                       duration_s=info["duration_s"], labels=info["timeline"])
    out = Path(out)
    write_text_atomic(out, html)
    return ReplayInfo(out, len(html.encode("utf-8")), info["keyframes"], info["bodies"],
                      info["duration_s"], info["speed"])
