"""`murdoch report RUN_DIR`: rebuild a run's summary.json and plots (and its replay)."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import click


@click.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--replay/--no-replay", default=False, show_default=True,
              help="Also rebuild replay.html from poses.jsonl.")
@click.option("--json", "as_json", is_flag=True, help="Print the whole summary as JSON.")
def report(run_dir: Path, replay: bool, as_json: bool) -> None:
    """Rebuild RUN_DIR's summary.json and plots from its events.jsonl."""
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
    tasks = s["tasks"]
    rtf = s["real_time_factor"]
    click.echo(f"run        {run.root}")
    click.echo(f"sim time   {s['sim_time_s']:.0f} s   real-time factor "
               f"{rtf if rtf is not None else '-'}")
    click.echo(f"tasks      introduced {tasks['introduced']}  executed {tasks['executed']}  "
               f"failed {tasks['failed']}  unachievable {tasks['unachievable']}  "
               f"reallocations {tasks['reallocations']}")
    waits = s["waits_s"]
    click.echo(f"no bid     first auction of {tasks['first_attempt_unallocatable']} task(s) "
               f"(allocated after backoff {tasks['then_allocated']}, unachievable after "
               f"backoff {tasks['unachievable_after_backoff']})")
    if waits["count"]:
        click.echo(f"waits      introduction to award: median {waits['median']:g} s, "
                   f"p95 {waits['p95']:g} s, max {waits['max']:g} s")
    click.echo(f"charging   {s['charging_trips']} completed trips ({s['charging_starts']} "
               f"charge starts)   robot failures {s['robot_failures']}")
    goal = s.get("goal")
    if goal is not None and goal["pushes"]["role_swap"] is not None:
        swap = goal["pushes"]["role_swap"]
        click.echo(f"role swap  {swap['robot']}: {swap['end_before']} end before, "
                   f"{swap['end_after']} end after: {'yes' if swap['swapped'] else 'NO'}")
    click.echo(f"messages   {s['messages']['total']} ({s['messages']['total_bytes']} bytes)")
    inv = s["invariant_terminal_states"]
    click.echo(f"invariant  every task ends in exactly one terminal state: "
               f"{'yes' if inv['holds'] else 'NO'}")
    if result.malformed_lines:
        click.echo(f"warning    {result.malformed_lines} malformed event line(s) skipped")
    click.echo(f"wrote      {run.summary}")
    for p in result.plots:
        click.echo(f"wrote      {p}")
    if result.replay is not None:
        click.echo(f"wrote      {result.replay}")
