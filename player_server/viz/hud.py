"""What the page around the 3-D view writes: robot labels, the clock and the legend.

Pure: these functions return meshcat commands. Each carries its data as the ``userData`` of
an invisible three.js object (``set_object`` replaces the object, so the viewer's stored scene
never grows with updates), and the page's overlay script (``overlay.js``) reads them and draws
plain HTML over the scene:

    robots/<name>/info   {"murdoch": "robot", name, state, stateColour, battery, task,
                          colour, marked}
    hud/clock            {"murdoch": "clock", t, text}
    hud/legend           {"murdoch": "legend", entries: [{label, colours, shape}, ...]}

A robot's info object hangs below the robot, so the overlay finds the robot's pose (and the
label's anchor) from its parents. Robot states, their colours and the other colours come from
`player_server.viz.scene`, so the view, the replay and the tests agree on them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from player_server.viz import scene

Command = dict[str, Any]
DATA_NAME = "murdoch-data"
STATE_NAMES = {scene.IDLE: "idle", scene.WORKING: "working", scene.CHARGING: "charging",
               scene.FAILED: "down"}


def hex_colour(colour: int) -> str:
    return f"#{colour & 0xFFFFFF:06x}"


def clock_text(time_s: float) -> str:
    s = int(max(0.0, time_s))
    return f"sim {s // 3600}:{(s % 3600) // 60:02d}:{s % 60:02d}"


def data_object(ids: scene.IdSource, data: Mapping[str, Any]) -> dict[str, Any]:
    """An empty three.js object carrying `data` (read by the page, never drawn)."""
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [],
        "materials": [],
        "object": {"uuid": ids.next(), "type": "Object3D", "name": DATA_NAME,
                   "userData": dict(data), "matrix": scene.pose_matrix(0.0, 0.0, 0.0, 0.0)},
    }


def robot_info(robot: str, state: str = scene.IDLE, battery_percent: float | None = None,
               task: str = "", target_colour: int | None = None) -> dict[str, Any]:
    """A robot's label block: name, battery, state and task -> target (with the colour the
    target is named by; `marked` when that colour is also a robot state's)."""
    return {
        "murdoch": "robot",
        "name": robot,
        "state": state,
        "stateColour": hex_colour(scene.STATE_COLOURS[state]),
        "battery": None if battery_percent is None else round(float(battery_percent)),
        "task": task,
        "colour": None if target_colour is None else hex_colour(target_colour),
        "marked": target_colour is not None and scene.needs_marker(target_colour),
    }


def robot_info_command(ids: scene.IdSource, info: Mapping[str, Any]) -> Command:
    return scene.set_object(f"{scene.robot_path(str(info['name']))}/info", data_object(ids, info))


def clock_command(ids: scene.IdSource, time_s: float) -> Command:
    t = max(0.0, float(time_s))
    return scene.set_object(f"{scene.ROOT}/hud/clock", data_object(
        ids, {"murdoch": "clock", "t": round(t, 3), "text": clock_text(t)}))


def legend_entries(layout: scene.SceneLayout, *, trails: bool = False,
                   lasers: bool = False) -> list[dict[str, Any]]:
    """What each colour and mark in the scene means: robot states, then the world's things."""
    entries: list[dict[str, Any]] = [
        {"label": f"robot {STATE_NAMES[s]}", "colours": [hex_colour(scene.STATE_COLOURS[s])],
         "shape": "square"}
        for s in scene.ROBOT_STATES
    ]
    entries.append({"label": "heading (front of a robot)",
                    "colours": [hex_colour(scene.NOSE_COLOUR)], "shape": "bar"})
    if layout.chargers:
        entries.append({"label": "charging pad",
                        "colours": _distinct(c.colour for c in layout.chargers),
                        "shape": "disc"})
    if layout.boxes:
        entries.append({"label": "box", "colours": _distinct(b.colour for b in layout.boxes),
                        "shape": "square"})
    if layout.objects:
        entries.append({"label": "object (ball, cylinder)",
                        "colours": _distinct(o.colour for o in layout.objects),
                        "shape": "disc"})
    if layout.markers:
        entries.append({"label": "goal marker",
                        "colours": _distinct(m.colour for m in layout.markers),
                        "shape": "disc"})
    things = [b.colour for b in layout.boxes] + [o.colour for o in layout.objects]
    if any(scene.needs_marker(c) for c in things):
        entries.append({"label": "ringed: a box or object in a robot-state colour",
                        "colours": [hex_colour(scene.MARKER_COLOUR)], "shape": "ring"})
    if layout.obstacles or layout.posts or layout.prisms:
        entries.append({"label": "obstacle",
                        "colours": _distinct([*(b.colour or scene.OBSTACLE_COLOUR
                                                for b in layout.obstacles),
                                              *(p.colour or scene.OBSTACLE_COLOUR
                                                for p in layout.prisms),
                                              *(p.colour for p in layout.posts)]),
                        "shape": "square"})
    entries.append({"label": "wall", "colours": _distinct(
        w.colour or scene.WALL_COLOUR for w in layout.walls) or [hex_colour(scene.WALL_COLOUR)],
                    "shape": "square"})
    if trails:
        entries.append({"label": "trail (where a robot drove)",
                        "colours": [hex_colour(scene.TRAIL_COLOUR)], "shape": "bar"})
    if lasers:
        entries.append({"label": "laser rays", "colours": [hex_colour(scene.LASER_COLOUR)],
                        "shape": "bar"})
    return entries


def _distinct(colours: Any, most: int = 6) -> list[str]:
    out: list[str] = []
    for c in colours:
        h = hex_colour(int(c))
        if h not in out:
            out.append(h)
    return out[:most]


def legend_command(ids: scene.IdSource, layout: scene.SceneLayout, *, trails: bool = False,
                   lasers: bool = False) -> Command:
    entries = legend_entries(layout, trails=trails, lasers=lasers)
    return scene.set_object(f"{scene.ROOT}/hud/legend", data_object(
        ids, {"murdoch": "legend", "entries": entries}))
