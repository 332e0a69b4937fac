"""Task parameters: parsing and checking (colours, numbers) with clear errors."""

from __future__ import annotations

from collections.abc import Mapping

COLOUR_NAMES: dict[str, int] = {
    "red": 0xFF0000,
    "green": 0x00FF00,
    "blue": 0x0000FF,
    "yellow": 0xFFFF00,
    "cyan": 0x00FFFF,
    "magenta": 0xFF00FF,
    "orange": 0xFF8000,
    "white": 0xFFFFFF,
}


class ParamError(ValueError):
    """A task parameter is missing or malformed."""


def colour_of(value: object) -> int:
    """0xRRGGBB from an int, "#rrggbb", "0xrrggbb" or a colour name."""
    if isinstance(value, bool):
        raise ParamError(f"colour: expected 0xRRGGBB, '#rrggbb' or a name, found {value!r}")
    if isinstance(value, int):
        if 0 <= value <= 0xFFFFFF:
            return value
        raise ParamError(f"colour: expected 0..0xFFFFFF, found {value:#x}")
    if isinstance(value, str):
        text = value.strip().lower()
        if text in COLOUR_NAMES:
            return COLOUR_NAMES[text]
        for prefix in ("#", "0x"):
            if text.startswith(prefix):
                try:
                    return colour_of(int(text[len(prefix):], 16))
                except ValueError:
                    break
        raise ParamError(f"colour: expected 0xRRGGBB, '#rrggbb' or a name, found {value!r}")
    raise ParamError(f"colour: expected 0xRRGGBB, '#rrggbb' or a name, found {value!r}")


def number(params: Mapping[str, object], key: str, default: float | None = None) -> float:
    if key not in params:
        if default is None:
            raise ParamError(f"missing parameter {key!r} (a number)")
        return default
    value = params[key]
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ParamError(f"parameter {key!r}: expected a number, found {value!r}")
    try:
        return float(value)
    except ValueError:
        raise ParamError(f"parameter {key!r}: expected a number, found {value!r}") from None


def parse_assignments(items: list[str] | tuple[str, ...]) -> dict[str, object]:
    """Parse KEY=VALUE strings (numbers become floats, other values stay strings)."""
    out: dict[str, object] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise ParamError(f"expected KEY=VALUE, found {item!r}")
        try:
            out[key.strip()] = float(raw)
        except ValueError:
            out[key.strip()] = raw.strip()
    return out
