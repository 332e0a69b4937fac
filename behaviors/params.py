"""Task parameters: parsing and checking (colours, numbers) with clear errors."""

from __future__ import annotations

from collections.abc import Mapping

from worlds.colours import parse_colour


class ParamError(ValueError):
    """A task parameter is missing or malformed."""


def colour_of(value: object) -> int:
    """0xRRGGBB from an int, "#rrggbb", "0xrrggbb" or a colour name: the spellings a world
    file accepts (`worlds.parse_colour`, one table for both)."""
    if isinstance(value, int) and not isinstance(value, bool) and not 0 <= value <= 0xFFFFFF:
        raise ParamError(f"colour: expected 0..0xFFFFFF, found {value:#x}")
    try:
        return parse_colour(value)
    except ValueError:
        raise ParamError(
            f"colour: expected 0xRRGGBB, '#rrggbb' or a name, found {value!r}") from None


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
