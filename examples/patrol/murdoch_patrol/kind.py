"""The ``patrol-waypoints`` task kind: drive to each waypoint in turn, round and round,
until the task's duration has passed."""

from __future__ import annotations

from collections.abc import Mapping

from murdoch_api import (
    Layer,
    ParamError,
    RobotProfile,
    ServoToLocation,
    Stage,
    TaskKind,
    TaskPlan,
    WeightedMetric,
    avoid_layers,
    battery_fraction,
    elapsed,
    elapsed_progress,
    negative_distance,
    number,
    signal,
)


def waypoints(text: str) -> list[tuple[float, float]]:
    """'1,2;3,-1' -> [(1.0, 2.0), (3.0, -1.0)]; ParamError on anything else."""
    try:
        points = [tuple(float(v) for v in p.split(",")) for p in text.split(";") if p.strip()]
    except ValueError:
        points = []
    if not points or any(len(p) != 2 for p in points):
        raise ParamError(f"waypoints: expected X,Y;X,Y;... such as 1,2;3,-1, found {text!r}")
    return [(p[0], p[1]) for p in points]


def build_patrol(p: Mapping[str, object], profile: RobotProfile) -> TaskPlan:
    duration = number(p, "duration_s")
    legs = tuple(
        Stage(f"leg-{i}", (*avoid_layers(profile, number(p, "safe_range_m")),
                           Layer(ServoToLocation(x, y, tolerance_m=number(p, "tolerance_m"),
                                                 max_speed_mps=number(p, "speed_mps")), 1)),
              until=signal("at-goal"))
        for i, (x, y) in enumerate(waypoints(str(p["waypoints"]))))
    return TaskPlan("patrol-waypoints", legs, repeat_from=0, done=elapsed(duration),
                    progress=elapsed_progress(duration))


PATROL = TaskKind(
    "patrol-waypoints", frozenset({"mobile"}),
    {"duration_s": 120.0, "tolerance_m": 0.4, "speed_mps": 0.4, "safe_range_m": 0.5},
    ("waypoints", "x", "y"), build_patrol,
    (WeightedMetric("distance", negative_distance(), 1.0),
     WeightedMetric("battery", battery_fraction, 0.5)),
    "drive a loop of waypoints (X,Y;X,Y;...) until duration_s has passed; x, y: the first",
)
"""Its place is the default one: its ``x`` and ``y`` (the first waypoint)."""
