"""Draw the floorplan bitmap of worlds/stage/pioneers.world (a 16 x 16 m map, 0.1 m/pixel).

    python tools/stage_floorplan.py worlds/stage/pioneers.png

Dark pixels are walls. The map's edge is left white: the world's floorplan sets
`boundary 1`, which walls it in.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: (row0, col0, row1, col1) inclusive pixel rectangles of wall, row 0 at the top (+y)
WALLS: tuple[tuple[int, int, int, int], ...] = (
    (49, 0, 51, 59),      # a wall across the upper left, y = +3 m, x from -8 to -2 m
    (100, 109, 159, 111),  # a wall up from the bottom, x = +3 m, y from -8 to -2 m
    (20, 120, 39, 139),   # a pillar block around (+5, +5) m
)
SIZE_PX = 160


def draw(path: Path) -> None:
    from PIL import Image, ImageDraw

    im = Image.new("L", (SIZE_PX, SIZE_PX), 255)
    pen = ImageDraw.Draw(im)
    for r0, c0, r1, c1 in WALLS:
        pen.rectangle((c0, r0, c1, r1), fill=0)
    im.save(path, optimize=True)


if __name__ == "__main__":
    draw(Path(sys.argv[1] if len(sys.argv) > 1 else "worlds/stage/pioneers.png"))
