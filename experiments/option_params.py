"""Experiments' own options on the command line: `Option` declarations as click options.

`murdoch run`, `soak` and `compare` offer the options of every registered experiment
(`click_params`); `own_values` keeps those of the chosen experiment and refuses one given
for another.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import click

from experiments.plugin import Experiment, Option, PluginError
from experiments.registry import shared_options


class _Parsed(click.ParamType):
    """An `Option.type` function as a click type: its ValueError is the one-line error."""

    def __init__(self, option: Option) -> None:
        self.option = option
        self.name = option.metavar or getattr(option.type, "__name__", "VALUE").upper()

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        if not isinstance(value, str):
            return value
        try:
            return self.option.type(value)
        except (ValueError, click.BadParameter) as exc:
            message = exc.format_message() if isinstance(exc, click.BadParameter) else str(exc)
            self.fail(message or f"cannot use {value!r}", param, ctx)


def _click_option(option: Option, owners: list[str]) -> click.Option:
    help_text = f"{', '.join(owners)}: {option.help}"
    if option.type is bool:
        return click.Option([option.flag, option.dest], is_flag=True,
                            default=bool(option.default), help=help_text)
    kind: Any = option.type if option.type in (str, int, float) else _Parsed(option)
    default = (tuple(option.default or ()) if option.multiple else option.default)
    return click.Option([option.flag, option.dest], type=kind, default=default,
                        multiple=option.multiple, metavar=option.metavar,
                        show_default=option.default not in (None, (), False),
                        help=help_text)


def _free(command: click.Command, option: Option, owners: list[str]) -> None:
    """An experiment's option must not take a flag of the command itself."""
    taken = {flag for p in command.params for flag in getattr(p, "opts", ())}
    taken |= {flag for p in command.params for flag in getattr(p, "secondary_opts", ())}
    if option.flag in taken or option.dest in {p.name for p in command.params}:
        raise PluginError(f"experiment {owners[0]!r}: option {option.flag} is one of "
                          f"`murdoch {command.name}`'s own options")


def add_params(command: click.Command, every: Mapping[str, Experiment]) -> None:
    """Add a click option to `command` for every experiment option of `every` (one per flag);
    a flag the command has itself is a `PluginError` naming the experiment."""
    for option, owners in shared_options(every).values():
        _free(command, option, owners)
        command.params.append(_click_option(option, owners))


def own_values(experiment: Experiment, every: Mapping[str, Experiment], values: Mapping[str, Any],
               ctx: click.Context | None) -> dict[str, Any]:
    """The values of `experiment`'s own options among the parsed `values`; an option of
    another experiment that was given is a `click.UsageError`."""
    own = {o.dest for o in experiment.options}
    for option, owners in shared_options(every).values():
        if option.dest in own or ctx is None:
            continue
        source = ctx.get_parameter_source(option.dest)
        if source is not None and source != click.core.ParameterSource.DEFAULT:
            raise click.UsageError(f"{option.flag} is an option of {', '.join(owners)}, not "
                                   f"of {experiment.name}")
    return {o.dest: values.get(o.dest, o.default) for o in experiment.options}


def add_passthrough_params(command: click.Command, every: Mapping[str, Experiment]) -> None:
    """Add the experiment options to a command that hands them on to `murdoch run` as text
    (`murdoch compare`): checked by `passthrough_args`, parsed by each run."""
    out = []
    for option, owners in shared_options(every).values():
        _free(command, option, owners)
        help_text = f"{', '.join(owners)}: {option.help} (passed to every run)"
        if option.type is bool:
            out.append(click.Option([option.flag, option.dest], is_flag=True, help=help_text))
        else:
            out.append(click.Option([option.flag, option.dest], default=None,
                                    multiple=option.multiple, metavar=option.metavar,
                                    help=help_text))
    command.params.extend(out)


def passthrough_args(experiment: Experiment, every: Mapping[str, Experiment],
                     values: Mapping[str, Any],
                     ctx: click.Context | None) -> tuple[list[str], dict[str, Any]]:
    """(the `murdoch run` arguments of `experiment`'s options that were given, the parsed
    values of all of its options); a value its `Option.type` refuses, or an option of
    another experiment, is a click error naming it."""
    own_values(experiment, every, {}, ctx)  # another experiment's option: refused
    args: list[str] = []
    parsed: dict[str, Any] = {}
    for option in experiment.options:
        raw = values.get(option.dest)
        if option.type is bool:
            parsed[option.dest] = bool(raw) or bool(option.default)
            args += [option.flag] if raw else []
            continue
        texts = list(raw or ()) if option.multiple else ([] if raw is None else [raw])
        kind = _Parsed(option)
        param = next((p for p in ctx.command.params if p.name == option.dest), None) \
            if ctx is not None else None
        converted = [kind.convert(t, param, ctx) for t in texts]
        for t in texts:
            args += [option.flag, str(t)]
        parsed[option.dest] = (tuple(converted) if option.multiple
                               else converted[0] if converted else option.default)
    return args, parsed
