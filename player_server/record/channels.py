"""What a run recording holds: its topics, their schemas and how each message is built.

Every message is JSON (MCAP message encoding ``json``) and every channel names its schema.
Display channels use Foxglove's well-known schemas (``foxglove.FrameTransforms``,
``foxglove.LaserScan``, ``foxglove.Log``, ``foxglove.SceneUpdate``), so Foxglove shows them in
its 3-D, Plot and Log panels; the others are plain JSON objects with a ``murdoch.*`` schema.
Times are simulation time: an MCAP log time of t nanoseconds is t ns after the run began.

This module is the one definition of the layout: the recorder writes through these builders
and the Player replay and ``murdoch record-info`` read through the names below.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import orjson

PROFILE = "murdoch"
ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"

# --- topics ---
WORLD_INFO = "/murdoch/world"
"""(t = 0) the world's name and every robot's devices: laser and sonar geometry, body size."""
WORLD_SCENE = "/world"
"""(t = 0) the static world as scene entities: floor, walls, obstacles, chargers, markers."""
BODIES_SCENE = "/bodies"
"""(t = 0) the shapes of boxes and objects, each in its own frame (moved by /tf)."""
ROBOTS_SCENE = "/robots"
"""every robot's body coloured by its state, and its task label; sent whenever one changes."""
TF = "/tf"
"""ground-truth poses of every robot, box, object and marker: transforms world -> body."""
EVENTS = "/events"
"""every run event except auction messages, as a Log (its text is the events.jsonl line)."""
MURDOCH = "/murdoch"
"""every MURDOCH auction message seen (events of kind ``message``), as a Log."""

WORLD_FRAME = "world"


def robot_topic(robot: str, what: str) -> str:
    """/<robot>/laser, /<robot>/sonar, /<robot>/sonar_ranges, /<robot>/odometry,
    /<robot>/battery, /<robot>/state, /<robot>/blobs."""
    return f"/{robot}/{what}"


LASER = "laser"
SONAR = "sonar"
SONAR_RANGES = "sonar_ranges"
ODOMETRY = "odometry"
BATTERY = "battery"
STATE = "state"
BLOBS = "blobs"
ROBOT_CHANNELS: tuple[str, ...] = (LASER, SONAR, SONAR_RANGES, ODOMETRY, BATTERY, STATE, BLOBS)

SONAR_BINS = 120
"""the sonar ring as a LaserScan: one range per 3 degrees around the robot, 0 where no echo."""

# --- schemas (JSON Schema of each message) ---
_TIME = {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                          "nsec": {"type": "integer", "minimum": 0}}}
_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}
_NUMBERS = {"type": "array", "items": {"type": "number"}}
_STR = {"type": "string"}
_NUM = {"type": "number"}
_BOOL = {"type": "boolean"}


def _obj(title: str, **props: Any) -> dict[str, Any]:
    return {"title": title, "type": "object", "properties": props}


_CUBE = _obj("foxglove.CubePrimitive", pose=_POSE, size=_VEC3, color=_COLOR)
_CYLINDER = _obj("foxglove.CylinderPrimitive", pose=_POSE, size=_VEC3, bottom_scale=_NUM,
                 top_scale=_NUM, color=_COLOR)
_TEXT = _obj("foxglove.TextPrimitive", pose=_POSE, billboard=_BOOL, font_size=_NUM,
             scale_invariant=_BOOL, color=_COLOR, text=_STR)
_ANY_LIST = {"type": "array", "items": {"type": "object"}}
_ENTITY = _obj(
    "foxglove.SceneEntity", timestamp=_TIME, frame_id=_STR, id=_STR,
    lifetime=_TIME, frame_locked=_BOOL,
    metadata={"type": "array", "items": _obj("foxglove.KeyValuePair", key=_STR, value=_STR)},
    arrows=_ANY_LIST, cubes={"type": "array", "items": _CUBE}, spheres=_ANY_LIST,
    cylinders={"type": "array", "items": _CYLINDER}, lines=_ANY_LIST, triangles=_ANY_LIST,
    texts={"type": "array", "items": _TEXT}, models=_ANY_LIST,
)

SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.FrameTransforms": _obj("foxglove.FrameTransforms", transforms={
        "type": "array", "items": _obj(
            "foxglove.FrameTransform", timestamp=_TIME, parent_frame_id=_STR,
            child_frame_id=_STR, translation=_VEC3, rotation=_QUAT)}),
    "foxglove.LaserScan": _obj("foxglove.LaserScan", timestamp=_TIME, frame_id=_STR,
                               pose=_POSE, start_angle=_NUM, end_angle=_NUM,
                               ranges=_NUMBERS, intensities=_NUMBERS),
    "foxglove.Log": _obj("foxglove.Log", timestamp=_TIME,
                         level={"type": "integer", "minimum": 0, "maximum": 5},
                         message=_STR, name=_STR, file=_STR,
                         line={"type": "integer", "minimum": 0}),
    "foxglove.SceneUpdate": _obj("foxglove.SceneUpdate", deletions=_ANY_LIST,
                                 entities={"type": "array", "items": _ENTITY}),
    "murdoch.WorldInfo": _obj("murdoch.WorldInfo", world=_STR, interval_s=_NUM,
                              robots={"type": "object"}),
    "murdoch.Odometry": _obj("murdoch.Odometry", timestamp=_TIME, x=_NUM, y=_NUM, yaw=_NUM,
                             vx=_NUM, vy=_NUM, vyaw=_NUM, stall=_BOOL, cmd_vx=_NUM,
                             cmd_vyaw=_NUM),
    "murdoch.Battery": _obj("murdoch.Battery", timestamp=_TIME, percent=_NUM,
                            charging={"type": "integer"}, volts=_NUM, watts=_NUM,
                            joules=_NUM),
    "murdoch.RobotState": _obj("murdoch.RobotState", timestamp=_TIME, state=_STR, label=_STR,
                               code={"type": "integer"}),
    "murdoch.SonarRanges": _obj("murdoch.SonarRanges", timestamp=_TIME, ranges=_NUMBERS),
    "murdoch.Blobs": _obj("murdoch.Blobs", timestamp=_TIME, width={"type": "integer"},
                          height={"type": "integer"}, blobs={"type": "array", "items": {
                              "type": "array", "items": _NUM}}),
}

TOPIC_SCHEMAS: dict[str, str] = {
    WORLD_INFO: "murdoch.WorldInfo",
    WORLD_SCENE: "foxglove.SceneUpdate",
    BODIES_SCENE: "foxglove.SceneUpdate",
    ROBOTS_SCENE: "foxglove.SceneUpdate",
    TF: "foxglove.FrameTransforms",
    EVENTS: "foxglove.Log",
    MURDOCH: "foxglove.Log",
}
ROBOT_SCHEMAS: dict[str, str] = {
    LASER: "foxglove.LaserScan",
    SONAR: "foxglove.LaserScan",
    SONAR_RANGES: "murdoch.SonarRanges",
    ODOMETRY: "murdoch.Odometry",
    BATTERY: "murdoch.Battery",
    STATE: "murdoch.RobotState",
    BLOBS: "murdoch.Blobs",
}


def schema_of(topic: str) -> str:
    """The schema name of a topic (ValueError for a topic not in the layout)."""
    if topic in TOPIC_SCHEMAS:
        return TOPIC_SCHEMAS[topic]
    parts = topic.split("/")
    if len(parts) == 3 and parts[0] == "" and parts[1] and parts[2] in ROBOT_SCHEMAS:
        return ROBOT_SCHEMAS[parts[2]]
    raise ValueError(f"{topic!r} is not a topic of a run recording")


def split_robot_topic(topic: str) -> tuple[str, str] | None:
    """('p1', 'laser') for /p1/laser; None for the run-wide topics."""
    if topic in TOPIC_SCHEMAS:
        return None
    parts = topic.split("/")
    if len(parts) == 3 and parts[0] == "" and parts[2] in ROBOT_SCHEMAS:
        return parts[1], parts[2]
    return None


def schema_bytes(name: str) -> bytes:
    return json.dumps(SCHEMAS[name], separators=(",", ":")).encode()


def encode(message: Mapping[str, Any]) -> bytes:
    """The message as compact JSON; ValueError if it holds a NaN or an infinity (JSON has
    neither), TypeError if it is not JSON data.

    The fast encoder writes non-finite numbers as ``null`` and refuses some JSON that the
    standard one takes (keys that are not strings): a body with a ``null`` in it, or one the
    fast encoder refused, is encoded again by the strict standard one, which raises on
    non-finite numbers and otherwise gives the same JSON value."""
    try:
        body = orjson.dumps(message)
    except orjson.JSONEncodeError:
        body = b"null"
    if b"null" in body:
        return json.dumps(message, separators=(",", ":"), allow_nan=False).encode()
    return body


# --- building blocks ---

def nanoseconds(t_s: float) -> int:
    return max(0, round(t_s * 1e9))


def stamp(t_s: float) -> dict[str, int]:
    ns = nanoseconds(t_s)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}


def yaw_of(q: Mapping[str, float]) -> float:
    """The yaw of a rotation about z (as written by `quaternion`)."""
    return 2.0 * math.atan2(float(q["z"]), float(q["w"]))


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw: float = 0.0) -> dict[str, Any]:
    return {"position": {"x": x, "y": y, "z": z}, "orientation": quaternion(yaw)}


def colour(rgb: int, alpha: float = 1.0) -> dict[str, float]:
    return {"r": ((rgb >> 16) & 0xFF) / 255.0, "g": ((rgb >> 8) & 0xFF) / 255.0,
            "b": (rgb & 0xFF) / 255.0, "a": alpha}


def cube(x: float, y: float, z: float, yaw: float, sx: float, sy: float, sz: float,
         rgb: int, alpha: float = 1.0) -> dict[str, Any]:
    return {"pose": pose(x, y, z, yaw), "size": {"x": sx, "y": sy, "z": sz},
            "color": colour(rgb, alpha)}


def cylinder(x: float, y: float, z: float, radius: float, height: float, rgb: int,
             alpha: float = 1.0) -> dict[str, Any]:
    return {"pose": pose(x, y, z), "size": {"x": 2 * radius, "y": 2 * radius, "z": height},
            "bottom_scale": 1.0, "top_scale": 1.0, "color": colour(rgb, alpha)}


def text(x: float, y: float, z: float, words: str, rgb: int = 0x111111) -> dict[str, Any]:
    return {"pose": pose(x, y, z), "billboard": True, "font_size": 14.0,
            "scale_invariant": True, "color": colour(rgb), "text": words}


def triangles(points: Sequence[tuple[float, float, float]], indices: Sequence[int],
              rgb: int, alpha: float = 1.0) -> dict[str, Any]:
    """A triangle list in its entity's frame: vertices and index triples."""
    return {"pose": pose(), "points": [{"x": x, "y": y, "z": z} for x, y, z in points],
            "color": colour(rgb, alpha), "colors": [], "indices": list(indices)}


def entity(t_s: float, frame_id: str, entity_id: str, *, cubes: Sequence[Any] = (),
           cylinders: Sequence[Any] = (), texts: Sequence[Any] = (),
           triangle_lists: Sequence[Any] = (), frame_locked: bool = False) -> dict[str, Any]:
    return {
        "timestamp": stamp(t_s), "frame_id": frame_id, "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": frame_locked, "metadata": [],
        "arrows": [], "cubes": list(cubes), "spheres": [], "cylinders": list(cylinders),
        "lines": [], "triangles": list(triangle_lists), "texts": list(texts), "models": [],
    }


def scene_update(entities: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    return {"deletions": [], "entities": list(entities)}


def frame_transforms(t_s: float, poses: Mapping[str, tuple[float, float, float]]
                     ) -> dict[str, Any]:
    """world -> body for every (x, y, yaw) pose, positions rounded to millimetres."""
    ts = stamp(t_s)
    return {"transforms": [
        {"timestamp": ts, "parent_frame_id": WORLD_FRAME, "child_frame_id": name,
         "translation": {"x": round(x, 3), "y": round(y, 3), "z": 0.0},
         "rotation": quaternion(round(yaw, 4))}
        for name, (x, y, yaw) in poses.items()
    ]}


def poses_of(message: Mapping[str, Any]) -> dict[str, tuple[float, float, float]]:
    """(x, y, yaw) by body from a /tf message."""
    out: dict[str, tuple[float, float, float]] = {}
    for tr in message.get("transforms", ()):
        if tr.get("parent_frame_id") != WORLD_FRAME:
            continue
        p = tr["translation"]
        out[str(tr["child_frame_id"])] = (float(p["x"]), float(p["y"]), yaw_of(tr["rotation"]))
    return out


def laser_scan(t_s: float, frame_id: str, mount: tuple[float, float, float, float],
               start_angle: float, end_angle: float, ranges: Sequence[float]) -> dict[str, Any]:
    mx, my, mz, myaw = mount
    return {"timestamp": stamp(t_s), "frame_id": frame_id, "pose": pose(mx, my, mz, myaw),
            "start_angle": start_angle, "end_angle": end_angle, "ranges": list(ranges),
            "intensities": []}


def sonar_ring_scan(t_s: float, frame_id: str, mounts: Sequence[tuple[float, float, float]],
                    ranges: Sequence[float], max_range: float) -> dict[str, Any]:
    """The echoes of a sonar ring as one LaserScan about the robot's origin: each echo
    (mount + range along the transducer's axis) in the bin of its bearing, at its
    distance from the origin; bins without an echo hold 0. No echo (a range at or beyond
    `max_range`) is left out."""
    bins = [0.0] * SONAR_BINS
    step = 2.0 * math.pi / SONAR_BINS
    for (mx, my, myaw), r in zip(mounts, ranges, strict=False):
        if not 0.0 < r < max_range:
            continue
        ex, ey = mx + r * math.cos(myaw), my + r * math.sin(myaw)
        k = round((math.atan2(ey, ex) + math.pi) / step) % SONAR_BINS
        bins[k] = round(math.hypot(ex, ey), 3)
    return {"timestamp": stamp(t_s), "frame_id": frame_id, "pose": pose(),
            "start_angle": -math.pi, "end_angle": math.pi - step, "ranges": bins,
            "intensities": []}


LOG_INFO = 2
LOG_WARNING = 3
LOG_ERROR = 4


def log_message(t_s: float, name: str, message: str, level: int = LOG_INFO) -> dict[str, Any]:
    return {"timestamp": stamp(t_s), "level": level, "message": message, "name": name,
            "file": "", "line": 0}
