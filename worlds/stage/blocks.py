"""A Stage model's `block`s: their polygons and z extents, and a robot body's outline.

Stage scales a model's blocks together into its `size`: x and y over the blocks' joint
bounds, centred on the model; z as a share of the tallest block's top.
"""

from __future__ import annotations

from collections.abc import Sequence

from worlds.polygon import convex_hull, is_axis_rectangle
from worlds.stage.syntax import StageError
from worlds.stage.tree import Reader, StageModel

Points = tuple[tuple[float, float], ...]


def read_block(b: StageModel, r: Reader) -> tuple[list[tuple[float, float]],
                                                  tuple[float, float]]:
    """The block's points (as written) and its z [lo hi]; StageError for fewer than 3."""
    br = Reader(f"block of {r.owner}", b.props, r.units, r.warnings)
    n = int(br.number("points", 0))
    pts = [br.numbers(f"point[{i}]", 2, (0.0, 0.0)) for i in range(n)]
    z = br.numbers("z", 2, (0.0, 1.0))
    br.has("color")
    br.finish(b.where)
    if n < 3:
        raise StageError(b.where, "a block with points >= 3 and point[i] [x y]", f"points {n}")
    return [(p[0], p[1]) for p in pts], (z[0], z[1])


def scale_into(polys: Sequence[Sequence[tuple[float, float]]], size: tuple[float, float]
               ) -> list[list[tuple[float, float]]]:
    """Stage's rule for a model's blocks: their joint bounds scaled to `size` (x, y),
    centred on the model; each polygon's points in the model's frame."""
    xs = [p[0] for poly in polys for p in poly]
    ys = [p[1] for poly in polys for p in poly]
    x0, y0 = min(xs), min(ys)
    w, h = max(xs) - x0 or 1.0, max(ys) - y0 or 1.0
    return [[((x - x0) / w * size[0] - size[0] / 2, (y - y0) / h * size[1] - size[1] / 2)
             for x, y in poly] for poly in polys]


def body_outline(m: StageModel, r: Reader, size: tuple[float, float]) -> Points:
    """The convex hull of a robot's blocks scaled into its size (x, y), about the size box's
    centre; empty when it has no blocks or the hull is that box (a rectangular body)."""
    polys = [read_block(b, r)[0] for b in m.parts if b.kind == "block"]
    if not any(polys):
        return ()
    hull = convex_hull([p for poly in scale_into(polys, size) for p in poly])
    if len(hull) < 3 or is_axis_rectangle(hull):
        return ()
    return hull
