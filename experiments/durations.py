"""Spans and moments as the command line writes them: '90m', '2h', 'p3@30m' (pure)."""

from __future__ import annotations

import re

import click

_DURATION_RE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([smh]?)\s*$")


def parse_duration_s(text: str) -> float:
    """'90m', '2h', '45s' or plain seconds."""
    m = _DURATION_RE.match(text)
    if not m:
        raise click.BadParameter(f"expected a duration such as 90m, 2h or 300s, got {text!r}")
    value, unit = float(m.group(1)), m.group(2) or "s"
    return value * {"s": 1.0, "m": 60.0, "h": 3600.0}[unit]


def parse_at(text: str) -> tuple[str, float]:
    """'p3@30m' -> ('p3', 1800.0)."""
    robot, sep, when = text.partition("@")
    if not sep or not robot:
        raise click.BadParameter(f"expected ROBOT@TIME such as p3@30m, got {text!r}")
    return robot, parse_duration_s(when)
