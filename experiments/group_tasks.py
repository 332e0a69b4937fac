"""Group tasks of the long-term domain: tasks that need two robots at once (pure).

A group task names what it needs as data (`GroupTask`: its kind, how many robots it needs
at once and, for each member, the kind of the member's own task, the equipment it needs and
its parameters), so that an allocator that forms coalitions can take it whole and one that
allocates single robots can be handed its members as separate tasks by a coordinator. Its
success is judged from the simulation alone (`PairJudge`), the same way whoever allocated it.

The one kind so far is ``watch-object-pair``: two robots watch one of the world's coloured
objects from opposite sides at once. Its members are two ``watch-object-side`` tasks (the
robot's task library: drive to a spot beside the object, face it, hold), one spot each. The
group is achieved when, for `hold_s` simulated seconds without a break, each spot has a
different mobile robot within `tolerance_m` of it.

`with_group_tasks` turns a fraction of a task stream into group tasks, with a random source
of its own, so that a stream without group tasks is exactly the stream it always was.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from experiments import events as ev
from experiments.task_source import PlannedTask
from worlds import WorldSpec
from worlds.polygon import distance as polygon_distance

WATCH_PAIR = "watch-object-pair"
WATCH_SIDE = "watch-object-side"
GROUP_KINDS: frozenset[str] = frozenset({WATCH_PAIR})

SIDE_DISTANCE_M = 1.2
"""How far from the object each watcher stands."""
CLEARANCE_M = 0.5
"""The least room a spot keeps from walls, obstacles and charging pads."""
TOLERANCE_M = 0.5
"""A robot this close to its spot is in place (the member task stops within 0.3 m)."""
HOLD_S = 10.0
"""Both in place this long, without a break, achieves the group."""
DEADLINE_S = 300.0
"""From introduction: the members must be in place together by then, or the group fails."""
AXES_DEG = (0.0, 45.0, 90.0, 135.0)
"""The lines through the object the two spots may lie on (opposite sides of it)."""


@dataclass(frozen=True)
class GroupMember:
    """One member of a group task: the single-robot task it runs, the equipment it needs
    (the robot's resources, as the task library names them) and that task's parameters."""

    kind: str
    equipment: frozenset[str]
    params: Mapping[str, Any]

    def as_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "equipment": sorted(self.equipment),
                "params": dict(self.params)}


@dataclass(frozen=True)
class GroupTask:
    """What a group task needs, as data: `required` robots at once, one per member."""

    kind: str
    members: tuple[GroupMember, ...]
    duration_s: float
    hold_s: float = HOLD_S
    tolerance_m: float = TOLERANCE_M
    deadline_s: float = DEADLINE_S
    target: Mapping[str, Any] = field(default_factory=dict)

    @property
    def required(self) -> int:
        return len(self.members)

    @property
    def spots(self) -> tuple[tuple[float, float], ...]:
        return tuple((float(m.params["x"]), float(m.params["y"])) for m in self.members)

    def as_params(self) -> dict[str, Any]:
        """The task's parameters as events.jsonl records them (and `from_params` reads)."""
        return {"required": self.required, "duration_s": self.duration_s,
                "hold_s": self.hold_s, "tolerance_m": self.tolerance_m,
                "deadline_s": self.deadline_s, **dict(self.target),
                "members": [m.as_dict() for m in self.members]}

    @classmethod
    def from_params(cls, kind: str, params: Mapping[str, Any]) -> GroupTask:
        members = tuple(GroupMember(str(m["kind"]), frozenset(m["equipment"]),
                                    dict(m["params"])) for m in params["members"])
        if len(members) != int(params.get("required", len(members))):
            raise ValueError(f"group task {kind}: required {params.get('required')} but "
                             f"{len(members)} members")
        known = {"required", "duration_s", "hold_s", "tolerance_m", "deadline_s", "members"}
        return cls(kind, members, float(params["duration_s"]),
                   float(params.get("hold_s", HOLD_S)),
                   float(params.get("tolerance_m", TOLERANCE_M)),
                   float(params.get("deadline_s", DEADLINE_S)),
                   {k: v for k, v in params.items() if k not in known})


# -- where the watchers stand ----------------------------------------------------------------


def _room(spec: WorldSpec, x: float, y: float) -> float:
    """Free room around (x, y): metres to the nearest wall, static obstacle or charger."""
    arena = spec.arena
    room = min(arena.half_x_m - abs(x), arena.size_y_m / 2.0 - abs(y))
    for ob in arena.obstacles:
        dx, dy = x - ob.pose.x, y - ob.pose.y
        if ob.shape == "cylinder":
            room = min(room, math.hypot(dx, dy) - ob.radius_m)
            continue
        if ob.shape == "polygon":
            room = min(room, polygon_distance((x, y), ob.placed()))
            continue
        c, s = math.cos(-ob.pose.yaw), math.sin(-ob.pose.yaw)
        lx, ly = c * dx - s * dy, s * dx + c * dy
        ex = max(abs(lx) - ob.size_x_m / 2.0, 0.0)
        ey = max(abs(ly) - ob.size_y_m / 2.0, 0.0)
        room = min(room, math.hypot(ex, ey))
    for ch in spec.chargers:
        room = min(room, math.hypot(x - ch.x, y - ch.y) - ch.radius_m)
    return room


def side_spots(spec: WorldSpec, x: float, y: float, rng: random.Random,
               distance_m: float = SIDE_DISTANCE_M) -> tuple[tuple[float, float], ...] | None:
    """Two spots on opposite sides of (x, y), `distance_m` from it, each with
    `CLEARANCE_M` of room; the line through them drawn from `AXES_DEG` (None: no line fits)."""
    fits = []
    for deg in AXES_DEG:
        a = math.radians(deg)
        pair = tuple((round(x + sign * distance_m * math.cos(a), 3),
                      round(y + sign * distance_m * math.sin(a), 3)) for sign in (1.0, -1.0))
        if all(_room(spec, px, py) >= CLEARANCE_M for px, py in pair):
            fits.append(pair)
    return rng.choice(fits) if fits else None


def member_equipment(kind: str) -> frozenset[str]:
    """What a member needs: the resources its task needs in the robots' task library."""
    from behaviors.library import TASKS

    return TASKS[kind].subjects


def _colour_name(colour: int) -> str:
    return f"#{colour:06x}"


def watch_pair(spec: WorldSpec, rng: random.Random, duration_s: float) -> GroupTask | None:
    """A ``watch-object-pair`` task on one of the world's objects (None: no object has room
    on two sides)."""
    objects = sorted(spec.objects, key=lambda o: o.name)
    rng.shuffle(objects)
    for obj in objects:
        spots = side_spots(spec, obj.pose.x, obj.pose.y, rng)
        if spots is None:
            continue
        colour = _colour_name(obj.colour)
        members = tuple(GroupMember(WATCH_SIDE, member_equipment(WATCH_SIDE), {
            "colour": colour, "x": sx, "y": sy, "duration_s": duration_s, "side": i})
            for i, (sx, sy) in enumerate(spots))
        return GroupTask(WATCH_PAIR, members, duration_s,
                         target={"object": obj.name, "colour": colour,
                                 "object_x": obj.pose.x, "object_y": obj.pose.y})
    return None


def with_group_tasks(stream: Iterator[PlannedTask | None], spec: WorldSpec,
                     rng: random.Random, rate: float) -> Iterator[PlannedTask | None]:
    """`stream` with each task replaced, with probability `rate`, by a group task at the same
    time and of the same length. `rng` is the group tasks' own, so `rate` 0 leaves the stream
    exactly as it was."""
    if not 0.0 <= rate <= 1.0:
        raise ValueError(f"the group task rate is a fraction in [0, 1], found {rate!r}")
    for planned in stream:
        if planned is None or rate == 0.0:
            yield planned
            continue
        if rng.random() < rate:
            length = float(planned.params.get("duration_s", 120.0))
            group = watch_pair(spec, rng, length)
            if group is not None:
                yield PlannedTask(planned.t_s, group.kind, group.as_params())
                continue
        yield planned


# -- judging ---------------------------------------------------------------------------------


def assign_spots(spots: Sequence[tuple[float, float]],
                 positions: Mapping[str, tuple[float, float]],
                 tolerance_m: float) -> tuple[str, ...] | None:
    """A different robot within `tolerance_m` of each spot (the nearest such assignment, in
    name order on ties), or None when some spot has nobody."""
    near = [sorted((math.hypot(px - sx, py - sy), name)
                   for name, (px, py) in positions.items()
                   if math.hypot(px - sx, py - sy) <= tolerance_m) for sx, sy in spots]

    def pick(i: int, taken: frozenset[str]) -> tuple[str, ...] | None:
        if i == len(near):
            return ()
        for _, name in near[i]:
            if name not in taken:
                rest = pick(i + 1, taken | {name})
                if rest is not None:
                    return (name, *rest)
        return None

    return pick(0, frozenset())


@dataclass
class PairJudge:
    """Has every spot of a group task been held by its own robot for `hold_s`?

    `update(now, positions)` with the ground-truth positions of the mobile robots returns
    the robots in place when the group is achieved at `now`, else None. A break (a spot
    empty) starts the hold again."""

    group: GroupTask
    since: float | None = None
    robots: tuple[str, ...] = ()

    def update(self, now: float,
               positions: Mapping[str, tuple[float, float]]) -> tuple[str, ...] | None:
        placed = assign_spots(self.group.spots, positions, self.group.tolerance_m)
        if placed is None:
            self.since, self.robots = None, ()
            return None
        if self.since is None:
            self.since = now
        self.robots = placed
        return placed if now - self.since >= self.group.hold_s - 1e-9 else None


def group_outcome(member_outcomes: Iterable[str]) -> str | None:
    """What a member's end makes of a group not yet achieved: the members' unachievable
    makes the group unachievable, any other end fails it (None: all still open)."""
    ended = list(member_outcomes)
    if "unachievable" in ended:
        return "unachievable"
    return "failed" if ended else None


def group_summary(events: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """summary.json's group task figures: how many were introduced and how each ended
    (`group_tasks_completed` apart, for tables), and how long the completed ones took from
    introduction to both members in place."""
    groups: set[str] = set()
    ends: dict[str, str] = {}
    in_place: list[float] = []
    for e in events:
        if e["kind"] == ev.TASK_INTRODUCED and e.get("group"):
            groups.add(str(e["task"]))
        elif e["kind"] == ev.TASK_OUTCOME and str(e["task"]) in groups:
            ends[str(e["task"])] = ev.counted_outcome(e)
            if e["outcome"] == ev.COMPLETED and "in_place_s" in e:
                in_place.append(float(e["in_place_s"]))
    counts = {k: sum(1 for o in ends.values() if o == k)
              for k in (ev.COMPLETED, ev.FAILED, ev.UNACHIEVABLE, ev.OPEN_AT_END)}
    return {
        "group_tasks": {"introduced": len(groups), **counts,
                        "in_place_mean_s": (round(sum(in_place) / len(in_place), 3)
                                            if in_place else None)},
        "group_tasks_completed": counts[ev.COMPLETED],
    }
