"""Stage colours: X11 names (`gray30`, `NavyBlue`) and `color_rgba [r g b a]`."""

from __future__ import annotations

import re

from worlds.colours import NAMED_COLOURS
from worlds.stage.syntax import Where
from worlds.stage.tree import Reader, StageModel, Warnings

_GREY = re.compile(r"gr[ae]y(\d{1,3})")


def stage_colour(name: str, where: Where, warnings: Warnings, default: int = 0x808080) -> int:
    """0xRRGGBB of an X11 colour name (case and spaces ignored); unknown: warned, default."""
    key = name.replace(" ", "").lower()
    if key in NAMED_COLOURS:
        return NAMED_COLOURS[key]
    m = _GREY.fullmatch(key)
    if m and int(m.group(1)) <= 100:
        v = round(int(m.group(1)) * 255 / 100)
        return (v << 16) | (v << 8) | v
    if key.startswith("#") and len(key) == 7:
        try:
            return int(key[1:], 16)
        except ValueError:
            pass
    from matplotlib.colors import CSS4_COLORS  # X11 names, as the web took them over

    hexcode = CSS4_COLORS.get(key)
    if isinstance(hexcode, str):
        return int(hexcode[1:], 16)
    warnings.once(f"colour:{key}", f"{where}: unknown colour {name!r}; grey used")
    return default


def model_colour(r: Reader, m: StageModel, warnings: Warnings, default: int) -> int:
    if r.has("color_rgba"):
        rgba = r.numbers("color_rgba", 4, (0.5, 0.5, 0.5, 1.0), min_n=3)
        to8 = [max(0, min(255, round(c * 255))) for c in rgba[:3]]
        return (to8[0] << 16) | (to8[1] << 8) | to8[2]
    if r.has("color"):
        return stage_colour(r.string("color", ""), r.where("color", m.where), warnings, default)
    return default
