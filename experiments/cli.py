"""The `murdoch` command.

Subcommands live in the packages that own them and are imported only when used, so that
`murdoch listen` starts quickly and does not pull in the simulator or matplotlib.
"""

from __future__ import annotations

import importlib

import click

# subcommand name -> "module:attribute" of a click command
SUBCOMMANDS: dict[str, str] = {
    "listen": "murdoch.pubsub_cli:listen",
    "announce": "murdoch.pubsub_cli:announce",
    "allocate": "murdoch.consensus_cli:allocate",
    "sweep": "murdoch.consensus_cli:sweep",
    "run": "experiments.run_cli:run",
    "report": "experiments.report_cli:report",
}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use."""

    def __init__(self, *args: object, lazy: dict[str, str], **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._lazy = dict(lazy)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(super().list_commands(ctx)) | set(self._lazy))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self._lazy:
            module_name, attr = self._lazy[cmd_name].split(":")
            try:
                module = importlib.import_module(module_name)
            except ModuleNotFoundError as exc:
                raise click.UsageError(
                    f"'{cmd_name}' is not available: {exc.name} is missing"
                ) from exc
            command = getattr(module, attr)
            if not isinstance(command, click.Command):
                raise TypeError(f"{self._lazy[cmd_name]} is not a click command")
            return command
        return super().get_command(ctx, cmd_name)


@click.group(cls=LazyGroup, lazy=SUBCOMMANDS)
@click.version_option(package_name="murdoch")
def main() -> None:
    """MURDOCH: multi-robot task allocation on simulated Player robots."""
