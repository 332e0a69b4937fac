"""`murdoch report RUN_DIR`: rebuild a run's summary.json and plots (and its replay)."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import click


@click.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--replay/--no-replay", default=False, show_default=True,
              help="Also rebuild replay.html from run.mcap.")
@click.option("--json", "as_json", is_flag=True, help="Print the whole summary as JSON.")
def report(run_dir: Path, replay: bool, as_json: bool) -> None:
    """Rebuild RUN_DIR's summary.json and plots from its events.jsonl."""
    from experiments.end_report import summary_lines
    from experiments.report import build_report
    from experiments.rundir import open_run_dir

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        run = open_run_dir(run_dir)
    except FileNotFoundError as exc:
        raise click.ClickException(str(exc)) from exc
    result = build_report(run, replay=replay)
    s = result.summary
    if as_json:
        click.echo(json.dumps(s, indent=2, sort_keys=True))
        return
    click.echo(f"run        {run.root}")
    for line in summary_lines(s):
        click.echo(line)
    if result.malformed_lines:
        click.echo(f"warning    {result.malformed_lines} malformed event line(s) skipped")
    click.echo(f"wrote      {run.summary}")
    for p in result.plots:
        click.echo(f"wrote      {p}")
    if result.replay is not None:
        click.echo(f"wrote      {result.replay}")
    for problem in result.problems:
        click.echo(f"error: {problem}", err=True)
    if result.problems:
        raise SystemExit(1)
