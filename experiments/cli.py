"""The `murdoch` command.

Subcommands live in the packages that own them and are imported only when used, so that
`murdoch listen` starts quickly and does not pull in the simulator or matplotlib.
"""

from __future__ import annotations

import importlib
from typing import NamedTuple

import click


class Subcommand(NamedTuple):
    target: str  # "module:attribute" of a click command
    summary: str


SUBCOMMANDS: dict[str, Subcommand] = {
    "listen": Subcommand("murdoch.pubsub_cli:listen", "Print live MURDOCH traffic."),
    "announce": Subcommand("murdoch.pubsub_cli:announce", "Auction one task, print the outcome."),
    "allocate": Subcommand("murdoch.consensus_cli:allocate", "Run CBBA or CBGA on a scenario."),
    "sweep": Subcommand("murdoch.consensus_cli:sweep", "Reproduce the CBGA paper's experiments."),
    "sweep-compare": Subcommand("murdoch.consensus_cli:sweep_compare",
                                "Paired differences between sweep runs, with standard errors."),
    "run": Subcommand("experiments.run_cli:run", "Run an experiment end to end."),
    "sweep-longterm": Subcommand("experiments.sweep_longterm:sweep_longterm",
                                 "Run the long-term experiment over task rates and seeds."),
    "compare": Subcommand("experiments.compare:compare",
                          "Run the allocators side by side over seeds; CSV, figure, table."),
    "soak": Subcommand("experiments.soak.cli:soak",
                       "Run the team for hours under random faults; check nothing was lost."),
    "soak-report": Subcommand("experiments.soak.cli:soak_report",
                              "Rebuild a soak run's report; exit 3 if an invariant broke."),
    "report": Subcommand("experiments.report_cli:report", "Rebuild a run's summary and plots."),
    "world": Subcommand("experiments.world_cli:world",
                        "World files: convert a Stage .world to a TOML world."),
    "record-info": Subcommand("experiments.record_cli:record_info",
                              "Channels, message counts and duration of a run's run.mcap."),
}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(super().list_commands(ctx)) | set(SUBCOMMANDS))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = SUBCOMMANDS.get(cmd_name)
        if entry is None:
            return super().get_command(ctx, cmd_name)
        from murdoch.plugin_loading import PluginError

        module_name, attr = entry.target.split(":")
        try:
            module = importlib.import_module(module_name)
        except PluginError as exc:  # a broken plugin: one line, and nothing starts
            click.echo(f"murdoch {cmd_name}: {exc}", err=True)
            ctx.exit(2)
        command = getattr(module, attr)
        if not isinstance(command, click.Command):
            raise TypeError(f"{entry.target} is not a click command")
        return command

    def invoke(self, ctx: click.Context) -> object:
        """A plugin found broken while a command runs (e.g. `murdoch report` of a run whose
        experiment's package is broken) is one line too."""
        from murdoch.plugin_loading import PluginError

        try:
            return super().invoke(ctx)
        except PluginError as exc:
            click.echo(f"murdoch: {exc}", err=True)
            ctx.exit(2)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, SUBCOMMANDS[name].summary) for name in sorted(SUBCOMMANDS)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=LazyGroup)
@click.version_option(package_name="murdoch")
@click.pass_context
def main(ctx: click.Context) -> None:
    """MURDOCH: multi-robot task allocation on simulated Player robots.

    Help is --help (on the group and on every command); -h is never help."""
    from worlds import WORLDS_DIR

    # where `murdoch allocate NAME` finds bundled scenarios (murdoch.consensus_cli)
    ctx.meta["murdoch.scenario_dirs"] = (WORLDS_DIR / "scenarios",)
