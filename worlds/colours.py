"""Colour names and parsing: colours are 0xRRGGBB integers."""

from __future__ import annotations

NAMED_COLOURS: dict[str, int] = {
    "red": 0xFF0000,
    "green": 0x00FF00,
    "blue": 0x0000FF,
    "yellow": 0xFFFF00,
    "cyan": 0x00FFFF,
    "magenta": 0xFF00FF,
    "orange": 0xFF8000,
    "purple": 0x8000FF,
    "pink": 0xFF80C0,
    "white": 0xFFFFFF,
    "black": 0x000000,
    "grey": 0x808080,
    "gray": 0x808080,
    "darkgrey": 0x404040,
    "lightgrey": 0xC0C0C0,
    "brown": 0x804000,
    "tan": 0xD2B48C,
}


def parse_colour(value: object) -> int:
    """Accept 0xRRGGBB integers, '#rrggbb' / '0xrrggbb' strings and the names above."""
    if isinstance(value, bool):
        raise ValueError(value)
    if isinstance(value, int):
        if 0 <= value <= 0xFFFFFF:
            return value
        raise ValueError(value)
    if isinstance(value, str):
        text = value.strip().lower()
        if text in NAMED_COLOURS:
            return NAMED_COLOURS[text]
        for prefix in ("#", "0x"):
            if text.startswith(prefix) and len(text) == len(prefix) + 6:
                try:
                    return int(text[len(prefix):], 16)
                except ValueError:
                    break
    raise ValueError(value)


def colour_rgb01(colour: int) -> tuple[float, float, float]:
    """0xRRGGBB -> (r, g, b) in [0, 1]."""
    return ((colour >> 16 & 0xFF) / 255.0, (colour >> 8 & 0xFF) / 255.0, (colour & 0xFF) / 255.0)


def colour_name(colour: int) -> str:
    """The name a person would use for a 0xRRGGBB colour: its own name in `NAMED_COLOURS`, or
    the name of the nearest named colour (RGB distance)."""
    for name, value in NAMED_COLOURS.items():
        if value == colour:
            return name

    def distance(value: int) -> int:
        return sum(((colour >> s & 0xFF) - (value >> s & 0xFF)) ** 2 for s in (16, 8, 0))

    return min(NAMED_COLOURS, key=lambda name: distance(NAMED_COLOURS[name]))
