"""Floorplan bitmaps: dark pixels are solid; runs of them merged into rectangles."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

#: a pixel is solid when its mean of R, G and B is below this (0..255)
DARK_BELOW = 128


class Rect(NamedTuple):
    """Pixels [row, row + rows) x [col, col + cols); row 0 is the image's top."""

    row: int
    col: int
    rows: int
    cols: int


def read_solid(path: Path) -> NDArray[np.bool_]:
    """The bitmap's solid pixels (True = dark). OSError if it cannot be read as an image."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            rgba = np.asarray(im.convert("RGBA"), dtype=np.float32)
    except UnidentifiedImageError as exc:
        raise OSError(f"not an image: {exc}") from None
    mean = rgba[..., :3].mean(axis=2)
    transparent = rgba[..., 3] < 128
    return (mean < DARK_BELOW) & ~transparent


def merge_runs(solid: NDArray[np.bool_]) -> list[Rect]:
    """Rectangles covering exactly the solid pixels: the runs of each row, a run merged with
    the identical run (same columns) of the rows below."""
    rows, _cols = solid.shape
    open_runs: dict[tuple[int, int], int] = {}  # (col, cols) -> first row
    out: list[Rect] = []
    for r in range(rows + 1):
        runs: set[tuple[int, int]] = set()
        if r < rows:
            line = solid[r]
            padded = np.concatenate(([False], line, [False])).astype(np.int8)
            edges = np.flatnonzero(np.diff(padded))
            for start, stop in zip(edges[::2], edges[1::2], strict=True):
                runs.add((int(start), int(stop - start)))
        for run, first in list(open_runs.items()):
            if run not in runs:
                out.append(Rect(first, run[0], r - first, run[1]))
                del open_runs[run]
        for run in runs:
            open_runs.setdefault(run, r)
    out.sort()
    return out
