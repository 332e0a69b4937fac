"""`murdoch world convert X.world > x.toml`: a Stage world as the project's TOML world."""

from __future__ import annotations

import sys

import click


@click.group()
def world() -> None:
    """World files: conversions."""


@world.command()
@click.argument("path", type=click.Path(dir_okay=False))
def convert(path: str) -> None:
    """Print the TOML world file of a Stage .world (or a TOML world, normalised)."""
    from worlds import WorldError, load_world
    from worlds.to_toml import world_to_toml

    try:
        spec = load_world(path)
    except WorldError as exc:
        click.echo(f"murdoch world convert: {exc}", err=True)
        sys.exit(2)
    click.echo(world_to_toml(spec), nl=False)
