"""Generated worlds: a ``[generate]`` section asks for N robots instead of listing them.

The section is expanded into the ordinary tables of a world file (the arena's size, robots,
chargers, objects, boxes) before the loader reads them, so generated things pass the same
checks as written ones. Everything is drawn from one seeded generator: the same section and
seed give the same world. ::

    [generate]
    robots = 100                 # required, 1..5000
    seed = 3                     # default: [sim] seed
    area_per_robot = 6.0         # m^2 of floor per robot: the arena's area
    aspect = 1.0                 # arena size_x / size_y (neither side under 4 m)
    spacing = 1.5                # m between the lattice slots things are placed on
    robots_per_charger = 5       # chargers = ceil(robots / robots_per_charger)
    charger_colour = "cyan"      charger_rate = 150.0   charger_radius = 0.45
    objects = 50                 object_colours = ["red", ...]   object_radius = 0.08
    boxes = 20                   box_colours = ["yellow", "orange"]   box_size = 0.3
    initial_charge = [0.5, 1.0]  # batteries start uniformly in this range
    [[generate.kinds]]           # robot kinds, drawn in proportion to their share
    name = "sentry"              # robots are named <name><number>
    share = 2
    colour = "darkgrey"          # ... and any key or device table of a [[robots]] entry
    [generate.kinds.laser]

Slots lie on a square lattice inside the walls; each thing takes a slot of its own (shuffled,
jittered by a tenth of the spacing), robots face a random way. A generated world lists no
robots, chargers, objects, boxes, markers or obstacles of its own, and gives no arena size.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from worlds.errors import WorldError
from worlds.reader import Table

MAX_ROBOTS = 5000
MIN_SIDE_M = 4.0
_WALL_MARGIN_M = 0.75  # slots keep this far from the walls
_LISTED = ("robots", "chargers", "objects", "boxes", "markers")


@dataclass(frozen=True)
class Kind:
    name: str
    share: float
    table: dict[str, Any]  # the [[robots]] keys: colour, devices, ...


@dataclass(frozen=True)
class Options:
    robots: int
    seed: int
    area_per_robot: float
    aspect: float
    spacing: float
    robots_per_charger: float
    charger_colour: object
    charger_rate: float
    charger_radius: float
    objects: int
    object_colours: tuple[object, ...]
    object_radius: float
    boxes: int
    box_colours: tuple[object, ...]
    box_size: float
    initial_charge: tuple[float, float]
    kinds: tuple[Kind, ...]


def _colours(t: Table, name: str, default: tuple[str, ...]) -> tuple[object, ...]:
    value = t.raw(name, list(default))
    if not isinstance(value, list) or not value:
        raise t.error(name, "a non-empty array of colours", value)
    for v in value:
        Table(t.file, t.path, {name: v}).colour(name)  # a bad one is named under this key
    return tuple(value)


def read_options(t: Table, default_seed: int,
                 check_robot: Callable[[Table], object]) -> Options:
    """The [generate] section's options, checked; ``check_robot`` parses a [[robots]] table
    (each kind's is checked once, under its own key)."""
    n = t.integer("robots", min_value=1)
    if n > MAX_ROBOTS:
        raise t.error("robots", f"an integer <= {MAX_ROBOTS}", n)
    kinds_t = t.array_of_tables("kinds")
    if not kinds_t:
        raise t.error("kinds", "at least one [[generate.kinds]] table", "none")
    kinds = []
    for kt in kinds_t:
        name = kt.string("name")
        if not name or not name.replace("_", "").isalnum():
            raise kt.error("name", "a name of letters, digits and _", name)
        share = kt.number("share", 1.0, positive=True)
        table = {k: v for k, v in kt.data.items() if k not in ("name", "share")}
        for reserved in ("pose", "fiducial_id"):
            if reserved in table:
                raise kt.error(reserved, "no " + reserved + " (the generator sets it)",
                               table[reserved])
        check_robot(Table(kt.file, kt.path, {**table, "name": name, "pose": [0.0, 0.0]}))
        kinds.append(Kind(name, share, table))
    names = [k.name for k in kinds]
    if len(set(names)) != len(names):
        raise t.error("kinds", "kinds with different names", names)
    opts = Options(
        robots=n,
        seed=t.integer("seed", default_seed, min_value=0),
        area_per_robot=t.number("area_per_robot", 6.0, positive=True, max_value=1e4),
        aspect=t.number("aspect", 1.0, min_value=0.1, max_value=10.0),
        spacing=t.number("spacing", 1.5, min_value=0.8, max_value=100.0),
        robots_per_charger=t.number("robots_per_charger", 5.0, min_value=1.0),
        charger_colour=t.raw("charger_colour", "cyan"),
        charger_rate=t.number("charger_rate", 150.0, positive=True),
        charger_radius=t.number("charger_radius", 0.45, positive=True, max_value=2.0),
        objects=t.integer("objects", math.ceil(n / 2), min_value=0),
        object_colours=_colours(t, "object_colours", ("red", "green", "blue", "purple")),
        object_radius=t.number("object_radius", 0.08, positive=True, max_value=1.0),
        boxes=t.integer("boxes", math.ceil(n / 5), min_value=0),
        box_colours=_colours(t, "box_colours", ("yellow", "orange")),
        box_size=t.number("box_size", 0.3, positive=True, max_value=1.0),
        initial_charge=_charge_range(t),
        kinds=tuple(kinds),
    )
    t.colour("charger_colour", "cyan")
    t.finish()
    return opts


def _charge_range(t: Table) -> tuple[float, float]:
    lo, hi = t.vector("initial_charge", 2, (0.5, 1.0))
    if not 0.0 <= lo <= hi <= 1.0:
        raise t.error("initial_charge", "[low, high] with 0 <= low <= high <= 1", [lo, hi])
    return lo, hi


def arena_size(o: Options) -> tuple[float, float]:
    """The arena's (size_x, size_y): area robots x area_per_robot at the given aspect, and
    neither side under `MIN_SIDE_M`."""
    area = o.robots * o.area_per_robot
    sy = math.sqrt(area / o.aspect)
    return round(max(sy * o.aspect, MIN_SIDE_M), 3), round(max(sy, MIN_SIDE_M), 3)


def kind_counts(kinds: tuple[Kind, ...], n: int) -> list[int]:
    """Robots of each kind in proportion to the shares (largest remainders get the rest)."""
    total = sum(k.share for k in kinds)
    exact = [n * k.share / total for k in kinds]
    counts = [math.floor(e) for e in exact]
    order = sorted(range(len(kinds)), key=lambda i: (-(exact[i] - counts[i]), i))
    for i in order[: n - sum(counts)]:
        counts[i] += 1
    return counts


def expand(data: dict[str, Any], file: Path, o: Options) -> dict[str, Any]:
    """The world file's data with the generated tables in place of the [generate] section."""
    for key in _LISTED:
        if key in data:
            raise WorldError(file, key, f"no [[{key}]] in a world with a [generate] section",
                             f"{len(data[key]) if isinstance(data[key], list) else 1} entries")
    arena = dict(data.get("arena", {})) if isinstance(data.get("arena"), dict) else {}
    for key in ("size", "obstacles"):
        if key in arena:
            raise WorldError(file, f"arena.{key}",
                             f"no arena {key} in a world with a [generate] section "
                             "(it is derived from generate.robots)", arena[key])
    sx, sy = arena_size(o)
    arena["size"] = [sx, sy]
    n_chargers = math.ceil(o.robots / o.robots_per_charger)
    slots = _slots(sx, sy, o.spacing)
    need = o.robots + n_chargers + o.objects + o.boxes
    if need > len(slots):
        raise WorldError(file, "generate", f"at most {len(slots)} robots, chargers, objects "
                         f"and boxes on a {sx:g} x {sy:g} m arena at spacing {o.spacing:g} m "
                         "(raise area_per_robot or lower spacing, objects or boxes)", need)
    rng = np.random.default_rng(o.seed)
    order = rng.permutation(len(slots))
    jitter = rng.uniform(-0.1 * o.spacing, 0.1 * o.spacing, (need, 2))
    places = [(round(float(slots[j][0] + dx), 3), round(float(slots[j][1] + dy), 3))
              for j, (dx, dy) in zip(order[:need].tolist(), jitter.tolist(), strict=True)]
    yaws = rng.uniform(-180.0, 180.0, o.robots)
    kinds = rng.permutation(np.repeat(np.arange(len(o.kinds)),
                                      kind_counts(o.kinds, o.robots)))
    charge = rng.uniform(o.initial_charge[0], o.initial_charge[1], o.robots)
    out = {k: v for k, v in data.items() if k != "generate"}
    out["arena"] = arena
    at = iter(places)
    out["chargers"] = [{"name": f"dock{i}", "position": list(next(at)),
                        "radius": o.charger_radius, "colour": o.charger_colour,
                        "rate": o.charger_rate} for i in range(n_chargers)]
    robots = []
    numbers = dict.fromkeys((k.name for k in o.kinds), 0)
    for i in range(o.robots):
        kind = o.kinds[int(kinds[i])]
        numbers[kind.name] += 1
        table = _deep_copy(kind.table)
        x, y = next(at)
        table.update(name=f"{kind.name}{numbers[kind.name]}",
                     pose=[x, y, round(float(yaws[i]), 1)])
        power = table.get("power")
        if isinstance(power, dict) and "initial_fraction" not in power:
            power["initial_fraction"] = round(float(charge[i]), 3)
        robots.append(table)
    out["robots"] = robots
    out["objects"] = [{"name": f"ball{i}", "pose": list(next(at)), "radius": o.object_radius,
                       "colour": o.object_colours[i % len(o.object_colours)]}
                      for i in range(o.objects)]
    out["boxes"] = [{"name": f"box{i}", "pose": [*next(at), 0.0],
                     "size": [o.box_size] * 3, "mass": 1.0,
                     "colour": o.box_colours[i % len(o.box_colours)]}
                    for i in range(o.boxes)]
    return out


def _slots(sx: float, sy: float, spacing: float) -> list[tuple[float, float]]:
    """Lattice points spacing apart, centred, at least the wall margin inside the walls."""
    def axis(size: float) -> list[float]:
        usable = size - 2 * _WALL_MARGIN_M
        if usable < 0:
            return []
        k = math.floor(usable / spacing) + 1
        first = -(k - 1) * spacing / 2
        return [first + i * spacing for i in range(k)]
    return [(x, y) for y in axis(sy) for x in axis(sx)]


def _deep_copy(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_deep_copy(v) for v in value]
    return value
