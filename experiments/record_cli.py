"""`murdoch record-info RUN`: what a run's recording holds."""

from __future__ import annotations

import json
from pathlib import Path

import click


def _rate(messages: int, duration_s: float) -> str:
    return f"{messages / duration_s:.2f}/s" if duration_s > 0 else "-"


@click.command("record-info")
@click.argument("run", type=click.Path(exists=True, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the facts as JSON.")
def record_info(run: Path, as_json: bool) -> None:
    """Print the channels, message counts and duration of RUN's run.mcap (RUN is a run
    directory or an .mcap file)."""
    from player_server.record.reader import RecordingError, read_info

    try:
        info = read_info(run)
    except RecordingError as exc:
        raise click.ClickException(str(exc)) from exc
    if as_json:
        click.echo(json.dumps({
            "path": str(info.path), "bytes": info.bytes, "complete": info.complete,
            "truncated": info.truncated, "chunks": info.chunks, "messages": info.messages,
            "start_s": info.start_ns / 1e9, "end_s": info.end_ns / 1e9,
            "duration_s": info.duration_s,
            "channels": {c.topic: {"schema": c.schema, "messages": c.messages}
                         for c in info.channels.values()},
        }, indent=2))
        return
    state = ("complete" if info.complete else
             "no summary (cut short); read up to its last whole record")
    click.echo(f"{info.path}: {info.bytes / 2**20:.2f} MiB, {state}")
    click.echo(f"duration: {info.duration_s:.1f} s simulated "
               f"({info.start_ns / 1e9:.1f} s to {info.end_ns / 1e9:.1f} s)")
    click.echo(f"messages: {info.messages} on {len(info.channels)} channels"
               + (f" in {info.chunks} chunks" if info.chunks else ""))
    width = max((len(c.topic) for c in info.channels.values()), default=5)
    swidth = max((len(c.schema) for c in info.channels.values()), default=6)
    click.echo(f"  {'topic':<{width}}  {'schema':<{swidth}}  {'messages':>8}  rate")
    for c in sorted(info.channels.values(), key=lambda c: c.topic):
        click.echo(f"  {c.topic:<{width}}  {c.schema:<{swidth}}  {c.messages:>8}  "
                   f"{_rate(c.messages, info.duration_s)}")
