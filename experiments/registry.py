"""The experiments the commands know: the built-in ones and those of installed packages.

Packages add experiments through the ``murdoch.experiments`` entry point group: each entry
names an `experiments.plugin.Experiment` (or a sequence of them). `experiments()` loads them
once per process and checks every declaration (`check_declaration`); a broken plugin is a
`PluginError` of one line, and the command does not start.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping

from behaviors.task_kinds import task_kinds
from experiments.plugin import Experiment, Option, PluginError, Supports
from murdoch.plugin_loading import load_group

GROUP = "murdoch.experiments"
BUILT_IN = ("longterm", "boxpush")


def _built_in() -> dict[str, Experiment]:
    from experiments.plugins.boxpush import BOXPUSH
    from experiments.plugins.longterm import LONGTERM

    return {LONGTERM.name: LONGTERM, BOXPUSH.name: BOXPUSH}


def check_declaration(experiment: object, where: str = "experiment") -> Experiment:
    """`experiment` if what it declares is usable (name, world, options, task kinds,
    supports and the methods the runner calls), else a `PluginError` naming the rule."""
    name = getattr(experiment, "name", None)
    if not isinstance(name, str) or not name or any(c.isspace() for c in name):
        raise PluginError(f"{where}: expected an experiment `name` without spaces, found "
                          f"{name!r}")
    what = f"{where}: experiment {name!r}"
    if not isinstance(getattr(experiment, "world", None), str):
        raise PluginError(f"{what}: expected a `world` name or .toml path (str)")
    for method in ("check", "config", "tasks", "referee", "faults", "summary_sections",
                   "plots", "end_lines", "verdict", "next_steps"):
        if not callable(getattr(experiment, method, None)):
            raise PluginError(f"{what}: has no method {method}() (start from ExperimentBase)")
    supports = getattr(experiment, "supports", None)
    if not isinstance(supports, Supports):
        raise PluginError(f"{what}: expected `supports` to be a Supports, found "
                          f"{type(supports).__name__}")
    _check_options(getattr(experiment, "options", None), what)
    kinds = getattr(experiment, "task_kinds", None)
    if not isinstance(kinds, tuple) or not all(isinstance(k, str) for k in kinds):
        raise PluginError(f"{what}: expected `task_kinds` to be a tuple of task kind names")
    known = task_kinds()
    unknown = [k for k in kinds if k not in known]
    if unknown:
        raise PluginError(f"{what}: task kind(s) {', '.join(unknown)} are not registered "
                          f"(register them in the murdoch.tasks entry point group)")
    return experiment  # type: ignore[return-value]


def _check_options(options: object, what: str) -> None:
    if not isinstance(options, tuple) or not all(isinstance(o, Option) for o in options):
        raise PluginError(f"{what}: expected `options` to be a tuple of Option")
    seen: set[str] = set()
    for o in options:
        if not o.flag.startswith("--") or len(o.flag) < 3 or " " in o.flag:
            raise PluginError(f"{what}: option {o.flag!r}: expected a flag such as --my-option")
        if o.flag in seen:
            raise PluginError(f"{what}: option {o.flag} is declared twice")
        if not callable(o.type):
            raise PluginError(f"{what}: option {o.flag}: `type` must turn the text into a "
                              "value (str, int, float, bool or a function)")
        seen.add(o.flag)


def _accept(obj: object, where: str) -> Iterable[Experiment]:
    found = obj if isinstance(obj, (list, tuple)) else (obj,)
    return [check_declaration(e, where) for e in found]


@functools.cache
def _installed() -> dict[str, Experiment]:
    built_in = {n: check_declaration(e, f"built-in experiment {n}")
                for n, e in _built_in().items()}
    found = load_group(GROUP, _accept, built_in)
    every = {**built_in, **found}
    shared_options(every)  # two experiments may share a flag only with the same meaning
    return every


def experiments() -> Mapping[str, Experiment]:
    """Every registered experiment by name (built-in first)."""
    return _installed()


def experiment(name: str | None) -> Experiment | None:
    """The registered experiment `name` (None: not one of them, e.g. an old run's name)."""
    return experiments().get(name) if name is not None else None


def supporting(what: str) -> list[str]:
    """The names of the experiments that support `what` ('soak' or 'compare')."""
    return [n for n, e in experiments().items() if getattr(e.supports, what)]


def shared_options(every: Mapping[str, Experiment]) -> dict[str, tuple[Option, list[str]]]:
    """Every experiment option by flag, with the experiments that declare it; a flag two
    experiments declare differently (type, default, repetition) is a `PluginError`."""
    out: dict[str, tuple[Option, list[str]]] = {}
    for name, e in every.items():
        for o in e.options:
            if o.flag not in out:
                out[o.flag] = (o, [name])
                continue
            first, owners = out[o.flag]
            if (first.type, first.default, first.multiple) != (o.type, o.default, o.multiple):
                raise PluginError(f"experiment {name!r}: option {o.flag} differs from the one "
                                  f"of {owners[0]!r} (type, default or repetition)")
            owners.append(name)
    return out
