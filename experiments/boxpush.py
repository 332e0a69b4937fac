"""The box-pushing domain's referee and stage hands (pure geometry plus serving-thread hooks).

`GoalWatch` measures the box's distance to the goal marker from the simulation's ground
truth (the robots never see it); the run ends when the box is within `radius_m`. `SimActions`
queues changes to the simulation (moving a switched-off pusher out of the way, placing it
back behind the other end of the box) and applies them on the serving thread, between steps.
`return_pose` and `park_pose` say where. `GoalPlan` is the paper's stresses of the goal: a
goal that moves during the run (`goal_at`) and the watch task re-targeted to another goal
marker at set times.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from worlds import WorldSpec

# How far behind the box's back face a returning pusher is placed (robot centre), metres.
RETURN_GAP_M = 0.9
# Default goal radius: the box counts as arrived when its centre is this close to the goal
# marker. The watcher stops about its own arrival range short of the marker and leads the
# box from `lead_m` behind, so the box cannot come much closer than about 2 m.
GOAL_RADIUS_M = 2.5


@dataclass(frozen=True, slots=True)
class BoxGoal:
    box: str
    goal: str
    goal_xy: tuple[float, float]
    box_half_depth_m: float
    box_half_length_m: float


def box_goal(world: WorldSpec) -> BoxGoal:
    """The largest box and the first marker of a box-pushing world."""
    if not world.boxes or not world.markers:
        raise ValueError(f"world {world.name!r} needs a box and a goal marker for boxpush")
    box = max(world.boxes, key=lambda b: b.size_x_m * b.size_y_m)
    goal = world.markers[0]
    return BoxGoal(box.name, goal.name, (goal.x, goal.y), box.size_x_m / 2.0,
                   box.size_y_m / 2.0)


def resolve_robot(name: str, names: Iterable[str]) -> str:
    """A robot's name, or a short form of it: 'p1' for 'pusher1' (same first letter and the
    same trailing number). Raises ValueError when it names no robot or several."""
    names = tuple(names)
    if name in names:
        return name
    head, digits = name[:1], name[1:]
    if head and digits.isdigit():
        found = [n for n in names if n.startswith(head) and n.endswith(digits)
                 and not n[: len(n) - len(digits)][-1:].isdigit()]
        if len(found) == 1:
            return found[0]
    raise ValueError(f"no robot {name!r}; robots: {', '.join(names)}")


@dataclass(frozen=True, slots=True)
class GoalPlan:
    """How the goal behaves during a run: `velocity_mps` moves the goal marker from the start
    (it stops `margin_m` from the walls); each (t_s, marker) of `retargets` gives the watch
    task that marker as its goal from t_s on."""

    velocity_mps: tuple[float, float] = (0.0, 0.0)
    retargets: tuple[tuple[float, str], ...] = ()
    margin_m: float = 0.6

    @property
    def moving(self) -> bool:
        return self.velocity_mps != (0.0, 0.0)

    def goal_at(self, start_xy: tuple[float, float], t_s: float,
                arena_xy: tuple[float, float]) -> tuple[float, float]:
        """Where a moving goal that was at `start_xy` at time 0 is at `t_s`."""
        hx, hy = arena_xy[0] / 2.0 - self.margin_m, arena_xy[1] / 2.0 - self.margin_m
        x = start_xy[0] + self.velocity_mps[0] * t_s
        y = start_xy[1] + self.velocity_mps[1] * t_s
        return max(-hx, min(hx, x)), max(-hy, min(hy, y))


def parse_velocity(text: str) -> tuple[float, float]:
    """'VX,VY' in metres per second, e.g. '0,-0.01'; ValueError says what was wrong."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        vx, vy = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"expected VX,VY in m/s such as 0,-0.01, got {text!r}") from None
    if not (math.isfinite(vx) and math.isfinite(vy)) or math.hypot(vx, vy) > 0.5:
        raise ValueError(f"goal velocity {text!r}: expected finite speeds up to 0.5 m/s")
    return vx, vy


def marker_goal(world: WorldSpec, name: str) -> tuple[tuple[float, float], int]:
    """(position, colour) of the goal marker `name`; ValueError names the markers there are."""
    for m in world.markers:
        if m.name == name:
            return (m.x, m.y), m.colour
    known = ", ".join(m.name for m in world.markers) or "none"
    raise ValueError(f"world {world.name!r} has no marker {name!r} (markers: {known})")


PUSH_ENDS = {"push-left-end": "left", "push-right-end": "right", "push-box": "middle"}
"""Where each pushing task pushes the box (its ends: left / right as seen from behind it)."""
OTHER_END = {"left": "right", "right": "left"}
SWITCH_ON_WAIT_S = 60.0
"""How long a switch-on may wait for the remaining pusher to work the other end."""


def end_offset(box_pose: tuple[float, float, float], goal_xy: tuple[float, float], end: str,
               bg: BoxGoal, inset_m: float = 0.2) -> float:
    """Signed offset along the box's long axis (its local +y) of `end` ('left' or 'right' as
    seen from behind the box, facing the goal), `inset_m` in from the end."""
    reach = bg.box_half_length_m - inset_m
    forward = math.cos(push_heading(box_pose, goal_xy) - box_pose[2]) > 0.0
    # facing along the box's +x, its +y is on the left; facing along -x, on the right
    left = reach if forward else -reach
    return left if end == "left" else -left


def end_at(box_pose: tuple[float, float, float], goal_xy: tuple[float, float],
           xy: tuple[float, float]) -> str:
    """The end of the box ('left' or 'right', seen from behind) a point is nearer to."""
    side = side_of(box_pose, xy)
    forward = math.cos(push_heading(box_pose, goal_xy) - box_pose[2]) > 0.0
    return "left" if (side >= 0.0) == forward else "right"


def side_of(box_pose: tuple[float, float, float], xy: tuple[float, float]) -> float:
    """Signed offset (metres) of a point along the box's long axis (its local +y)."""
    bx, by, yaw = box_pose
    return -(xy[0] - bx) * math.sin(yaw) + (xy[1] - by) * math.cos(yaw)


def push_heading(box_pose: tuple[float, float, float], goal_xy: tuple[float, float]) -> float:
    """The box's pushing direction (its local +x or -x, whichever faces the goal)."""
    bx, by, yaw = box_pose
    to_goal = math.atan2(goal_xy[1] - by, goal_xy[0] - bx)
    if math.cos(to_goal - yaw) >= 0.0:
        return yaw
    return yaw + math.pi


def return_pose(
    box_pose: tuple[float, float, float], goal_xy: tuple[float, float], side_m: float,
    bg: BoxGoal, gap_m: float = RETURN_GAP_M,
) -> tuple[float, float, float]:
    """Behind the box (away from the goal), `side_m` along its long axis, facing the box."""
    bx, by, yaw = box_pose
    heading = push_heading(box_pose, goal_xy)
    back = bg.box_half_depth_m + gap_m
    # the long axis (box +y) in the world
    ux, uy = -math.sin(yaw), math.cos(yaw)
    x = bx - back * math.cos(heading) + side_m * ux
    y = by - back * math.sin(heading) + side_m * uy
    return x, y, math.atan2(math.sin(heading), math.cos(heading))


def odometry_at(start: tuple[float, float, float],
                pose: tuple[float, float, float]) -> tuple[float, float, float]:
    """The odometry reading of a robot at world `pose` whose odometry started (0, 0, 0) at
    world `start`: what it would read had it driven there without slipping."""
    x0, y0, yaw0 = start
    dx, dy = pose[0] - x0, pose[1] - y0
    c, s = math.cos(-yaw0), math.sin(-yaw0)
    yaw = pose[2] - yaw0
    return dx * c - dy * s, dx * s + dy * c, math.atan2(math.sin(yaw), math.cos(yaw))


def park_pose(world: WorldSpec, index: int) -> tuple[float, float, float]:
    """A spot along the arena's far (+y) wall, out of everybody's way, one per index."""
    sx, sy = world.arena.size_x_m, world.arena.size_y_m
    return -sx / 2.0 + 0.6 + 0.8 * index, sy / 2.0 - 0.5, 0.0


class GoalWatch:
    """Measures the box's ground-truth distance to the goal on the serving thread."""

    def __init__(self, bg: BoxGoal, radius_m: float = GOAL_RADIUS_M,
                 robots: tuple[str, ...] = ()) -> None:
        self.bg = bg
        self.goal_xy = bg.goal_xy  # the current goal (it may move, or be another marker)
        self.robots = robots
        self.robot_poses: dict[str, tuple[float, float, float]] = {}
        self.radius_m = radius_m
        self.box_pose: tuple[float, float, float] | None = None
        self.distance_m = math.inf
        self.reached_at_s: float | None = None

    def sample(self, sim: Any, t: float) -> None:
        pose = tuple(float(v) for v in sim.get_pose(self.bg.box))
        self.box_pose = (pose[0], pose[1], pose[2])
        poses = {}
        for name in self.robots:
            x, y, yaw = sim.get_pose(name)
            poses[name] = (float(x), float(y), float(yaw))
        self.robot_poses = poses  # replaced whole: readers on other threads see one or the other
        d = math.hypot(self.goal_xy[0] - pose[0], self.goal_xy[1] - pose[1])
        self.distance_m = d
        if d <= self.radius_m and self.reached_at_s is None:
            self.reached_at_s = t


class SimActions:
    """Changes to the simulation queued by any thread, applied between steps."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._queue: deque[Callable[[Any], None]] = deque()

    def put(self, action: Callable[[Any], None]) -> None:
        with self._lock:
            self._queue.append(action)

    def apply(self, sim: Any, t: float) -> None:
        with self._lock:
            actions = list(self._queue)
            self._queue.clear()
        for action in actions:
            action(sim)
