"""What the scene draws of a world: its shapes and their layout, from the world file.

`layout_from_world` turns a `worlds.WorldSpec` into a `SceneLayout` (arena, obstacles as
boxes, posts and polygon prisms, markers, chargers, boxes, objects, robots, lasers);
`player_server.viz.scene` makes the viewer commands that draw it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from worlds import WorldSpec

ROOT = "/murdoch"
FLOOR_COLOUR = 0xE4E0D4


@dataclass(frozen=True, slots=True)
class Block:
    """A box-shaped thing: centre, yaw and full sizes in metres."""

    name: str
    x_m: float
    y_m: float
    yaw_rad: float
    size_x_m: float
    size_y_m: float
    size_z_m: float
    colour: int


@dataclass(frozen=True, slots=True)
class Prism:
    """An upright polygon prism (a polygon obstacle): its outline in world coordinates, the
    heights of its bottom and top."""

    name: str
    points: tuple[tuple[float, float], ...]
    bottom_m: float
    top_m: float
    colour: int


@dataclass(frozen=True, slots=True)
class Disc:
    """A flat round marker (charging station) or a round object."""

    name: str
    x_m: float
    y_m: float
    radius_m: float
    height_m: float
    colour: int


@dataclass(frozen=True, slots=True)
class RobotShape:
    name: str
    length_m: float
    width_m: float
    x_m: float
    y_m: float
    yaw_rad: float
    offset_x_m: float = 0.0  # body centre ahead of the robot's origin
    outline: tuple[tuple[float, float], ...] = ()  # the body's outline about its centre


@dataclass(frozen=True, slots=True)
class LaserShape:
    """Where a robot's laser sits and what it covers (robot frame)."""

    robot: str
    x_m: float
    y_m: float
    yaw_rad: float
    min_angle_rad: float
    max_angle_rad: float
    samples: int
    max_range_m: float


@dataclass(frozen=True, slots=True)
class SceneLayout:
    """Everything drawn, with initial poses; dynamic bodies are moved by name later."""

    x_min_m: float
    y_min_m: float
    x_max_m: float
    y_max_m: float
    floor_colour: int = FLOOR_COLOUR
    walls: tuple[Block, ...] = ()
    obstacles: tuple[Block, ...] = ()
    posts: tuple[Disc, ...] = ()  # static upright cylinders (round obstacles)
    prisms: tuple[Prism, ...] = ()  # static polygon obstacles
    markers: tuple[Disc, ...] = ()  # visual-only posts, which may be moved
    chargers: tuple[Disc, ...] = ()
    boxes: tuple[Block, ...] = ()
    objects: tuple[Disc, ...] = ()
    robots: tuple[RobotShape, ...] = ()
    lasers: tuple[LaserShape, ...] = ()

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.x_min_m + self.x_max_m) / 2.0, (self.y_min_m + self.y_max_m) / 2.0)

    @property
    def extent_m(self) -> float:
        return max(self.x_max_m - self.x_min_m, self.y_max_m - self.y_min_m)

    def body_paths(self) -> dict[str, str]:
        """Scene path of every body that moves, keyed by its simulation name."""
        paths = {b.name: f"{ROOT}/boxes/{b.name}" for b in self.boxes}
        paths.update({o.name: f"{ROOT}/objects/{o.name}" for o in self.objects})
        paths.update({m.name: f"{ROOT}/markers/{m.name}" for m in self.markers})
        paths.update({r.name: robot_path(r.name) for r in self.robots})
        return paths


def robot_path(name: str) -> str:
    return f"{ROOT}/robots/{name}"


def layout_from_world(spec: WorldSpec) -> SceneLayout:
    """The scene of a world file (`worlds.load_world`): arena centred on the origin."""
    arena = spec.arena
    hx, hy, th, wh = arena.half_x_m, arena.half_y_m, arena.wall_thickness_m, arena.wall_height_m
    wc = arena.wall_colour
    walls = (
        Block("north", 0.0, hy + th / 2, 0.0, arena.size_x_m + 2 * th, th, wh, wc),
        Block("south", 0.0, -hy - th / 2, 0.0, arena.size_x_m + 2 * th, th, wh, wc),
        Block("east", hx + th / 2, 0.0, 0.0, th, arena.size_y_m, wh, wc),
        Block("west", -hx - th / 2, 0.0, 0.0, th, arena.size_y_m, wh, wc),
    )
    obstacles = tuple(
        Block(o.name, o.pose.x, o.pose.y, o.pose.yaw, o.size_x_m, o.size_y_m, o.height_m, o.colour)
        for o in arena.obstacles
        if o.shape == "box"
    )
    posts = tuple(
        Disc(o.name, o.pose.x, o.pose.y, o.radius_m, o.height_m, o.colour)
        for o in arena.obstacles
        if o.shape == "cylinder"
    )
    prisms = tuple(Prism(o.name, o.placed(), o.base_m, o.top_m, o.colour)
                   for o in arena.obstacles if o.shape == "polygon")
    markers = tuple(Disc(m.name, m.x, m.y, m.radius_m, m.height_m, m.colour) for m in spec.markers)
    return SceneLayout(
        x_min_m=-hx,
        y_min_m=-hy,
        x_max_m=hx,
        y_max_m=hy,
        floor_colour=arena.floor_colour,
        walls=walls,
        obstacles=obstacles,
        posts=posts,
        prisms=prisms,
        markers=markers,
        chargers=tuple(Disc(c.name, c.x, c.y, c.radius_m, 0.006, c.colour) for c in spec.chargers),
        boxes=tuple(
            Block(b.name, b.pose.x, b.pose.y, b.pose.yaw, b.size_x_m, b.size_y_m, b.size_z_m,
                  b.colour)
            for b in spec.boxes
        ),
        objects=tuple(
            Disc(o.name, o.pose.x, o.pose.y, o.radius_m, o.height_m, o.colour)
            for o in spec.objects
        ),
        robots=tuple(
            RobotShape(r.name, r.body.length_m, r.body.width_m, r.pose.x, r.pose.y, r.pose.yaw,
                       r.body.offset_x_m, r.body.outline)
            for r in spec.robots
            if r.mobile
        ),
        lasers=tuple(
            LaserShape(r.name, r.devices.laser.pose.x, r.devices.laser.pose.y,
                       r.devices.laser.pose.yaw, r.devices.laser.min_angle_rad,
                       r.devices.laser.max_angle_rad, r.devices.laser.samples,
                       r.devices.laser.max_range_m)
            for r in spec.robots
            if r.mobile and r.devices.laser is not None
        ),
    )
