"""The public experiment and task kind API: every registered plugin honours its contract,
plugins come from entry points, and a broken one is named in one line."""

from __future__ import annotations

import importlib
import textwrap
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import pytest

from behaviors import task_kinds as tk
from behaviors.task_kinds import check_task_kind
from behaviors.task_place import default_place
from experiments import registry
from experiments.option_params import add_passthrough_params, passthrough_args
from experiments.plugin import (
    ExperimentBase,
    Option,
    PlannedTask,
    RunOptions,
    Supports,
)
from experiments.plugin_check import check_experiment
from murdoch.plugin import ContractError, PluginError


@pytest.mark.parametrize("name", sorted(registry.experiments()))
def test_every_registered_experiment_honours_the_contract(name: str) -> None:
    check_experiment(name)


@pytest.mark.parametrize("name", sorted(tk.task_kinds()))
def test_every_registered_task_kind_honours_the_contract(name: str) -> None:
    kind = check_task_kind(tk.task_kinds()[name])
    if kind.duration_param is not None and kind.duration_param in kind.defaults:
        assert kind.duration_s({k: 1.0 for k in kind.required}) > 0


def test_every_experiment_names_only_registered_task_kinds() -> None:
    for e in registry.experiments().values():
        assert set(e.task_kinds) <= set(tk.task_kinds()), e.name


@dataclass(frozen=True)
class Scripted(ExperimentBase):
    """A test experiment whose task stream is given."""

    stream: tuple[PlannedTask, ...] = ()

    def tasks(self, spec: Any, options: RunOptions) -> Iterator[PlannedTask | None]:
        return iter([*self.stream, None])


def _goto(t: float, **params: Any) -> PlannedTask:
    return PlannedTask(t, "goto-goal", {"x": 1.0, "y": 2.0, **params})


def test_check_experiment_names_the_rule_a_task_stream_breaks() -> None:
    good = Scripted("scripted", "simple", task_kinds=("goto-goal",), stream=(_goto(5.0),))
    check_experiment(good)
    cases = {
        "its kind is not in task_kinds": Scripted(
            "s", "simple", task_kinds=("object-tracking",), stream=(_goto(5.0),)),
        "its time must be within the run": Scripted(
            "s", "simple", task_kinds=("goto-goal",), stream=(_goto(-1.0),)),
        "a user task needs a positive duration": Scripted(
            "s", "simple", task_kinds=("goto-goal",), stream=(_goto(5.0, timeout_s=0.0),)),
        "introduced nothing": Scripted("s", "simple", task_kinds=("goto-goal",)),
        "missing parameter": Scripted(
            "s", "simple", task_kinds=("goto-goal",),
            stream=(PlannedTask(5.0, "goto-goal", {"x": 1.0}),)),
    }
    for rule, experiment in cases.items():
        with pytest.raises(ContractError, match=rule):
            check_experiment(experiment)


def test_check_experiment_wants_the_same_tasks_from_the_same_seed() -> None:
    @dataclass(frozen=True)
    class Drifting(ExperimentBase):
        calls: list[int] = None  # type: ignore[assignment]

        def tasks(self, spec: Any, options: RunOptions) -> Iterator[PlannedTask | None]:
            self.calls.append(1)
            return iter([_goto(float(len(self.calls))), None])

    with pytest.raises(ContractError, match="the same tasks for the same world"):
        check_experiment(Drifting("drifting", "simple", task_kinds=("goto-goal",), calls=[]))


def test_a_declaration_that_breaks_the_rules_is_refused_in_one_line() -> None:
    base = {"name": "x", "world": "simple", "task_kinds": ("goto-goal",)}
    cases = {
        "declared twice": {"options": (Option("--a", "a"), Option("--a", "again"))},
        "not registered": {"task_kinds": ("teleport",)},
        "expected an experiment `name` without spaces": {"name": "two words"},
    }
    for rule, over in cases.items():
        with pytest.raises(PluginError, match=rule) as info:
            registry.check_declaration(Scripted(**{**base, **over}))
        assert "\n" not in str(info.value)
    with pytest.raises(PluginError, match="`supports` to be a Supports"):
        registry.check_declaration(Scripted("x", "simple", supports=None))  # type: ignore[arg-type]


def test_an_option_may_not_take_a_flag_of_the_command() -> None:
    from experiments.option_params import add_params

    clash = Scripted("clash", "simple", options=(Option("--seed", "clash"),))
    command = click.Command("run", params=[click.Option(["--seed"], type=int)])
    with pytest.raises(PluginError, match="option --seed is one of `murdoch run`'s own"):
        add_params(command, {"clash": clash})


def test_two_experiments_may_share_an_option_only_with_the_same_meaning() -> None:
    a = Scripted("a", "simple", options=(Option("--rate", "r", type=float, default=1.0),))
    b = Scripted("b", "simple", options=(Option("--rate", "r", type=float, default=1.0),))
    c = Scripted("c", "simple", options=(Option("--rate", "r", type=int, default=1),))
    shared = registry.shared_options({"a": a, "b": b})
    assert shared["--rate"][1] == ["a", "b"]
    with pytest.raises(PluginError, match="differs from the one of 'a'"):
        registry.shared_options({"a": a, "c": c})


def test_options_handed_on_are_checked_by_their_type_and_kept_as_text() -> None:
    every = {"a": Scripted("a", "simple", options=(
        Option("--count", "n", type=int, default=2),
        Option("--at", "when", type=lambda t: t.split("@"), multiple=True)))}
    command = click.Command("c")
    add_passthrough_params(command, every)
    ctx = command.make_context("c", ["--count", "3", "--at", "p1@5"])
    args, parsed = passthrough_args(every["a"], every, ctx.params, ctx)
    assert args == ["--count", "3", "--at", "p1@5"]
    assert parsed == {"count": 3, "at": (["p1", "5"],)}
    bad = command.make_context("c", ["--count", "three"])
    with pytest.raises(click.BadParameter, match="three") as info:
        passthrough_args(every["a"], every, bad.params, bad)
    assert "--count" in info.value.format_message()


def test_a_task_kind_must_say_how_long_it_runs() -> None:
    kind = tk.task_kinds()["goto-goal"]
    from dataclasses import replace

    with pytest.raises(PluginError, match="has no default and is not required"):
        check_task_kind(replace(kind, duration_param="length_s"))
    assert default_place({"x": 1, "y": 2}, None) == (1.0, 2.0)  # type: ignore[arg-type]


# -- entry points -----------------------------------------------------------------------
def _install(root: Path, name: str, entry_points: str, module: str = "") -> None:
    """A distribution on sys.path as pip would leave it (metadata and entry points)."""
    dist = root / f"{name}-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n",
                                   encoding="utf-8")
    (dist / "entry_points.txt").write_text(textwrap.dedent(entry_points), encoding="utf-8")
    if module:
        (root / f"{name}.py").write_text(textwrap.dedent(module), encoding="utf-8")


@pytest.fixture
def site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    tk._installed.cache_clear()
    registry._installed.cache_clear()
    yield tmp_path
    tk._installed.cache_clear()
    registry._installed.cache_clear()


MODULE = """
    from dataclasses import replace
    from behaviors.library import TASKS
    from experiments.plugin import ExperimentBase, PlannedTask, Supports

    KIND = replace(TASKS["goto-goal"], name="goto-twice")

    class Twice(ExperimentBase):
        def tasks(self, spec, options):
            return iter([PlannedTask(5.0, "goto-twice", {"x": 0.0, "y": 0.0}), None])

    TWICE = Twice("twice", "simple", task_kinds=("goto-twice",), supports=Supports(soak=True))
"""


def test_installed_plugins_join_the_registries(site: Path) -> None:
    _install(site, "plugin_ok", """
        [murdoch.tasks]
        goto-twice = plugin_ok:KIND
        [murdoch.experiments]
        twice = plugin_ok:TWICE
    """, MODULE)
    assert "goto-twice" in tk.task_kinds() and "goto-twice" in tk.task_kinds()
    assert "twice" in registry.experiments() and "twice" in registry.supporting("soak")
    check_experiment("twice")


@pytest.mark.parametrize(("name", "entry", "module", "message"), [
    ("plugin_gone", "[murdoch.tasks]\nx = plugin_gone.kinds:K\n", "",
     "cannot be imported: ModuleNotFoundError"),
    ("plugin_taken", "[murdoch.tasks]\ngoto-goal = plugin_taken:KIND\n",
     "from behaviors.library import TASKS\nKIND = TASKS['goto-goal']\n",
     "the name 'goto-goal' is taken by a built-in one"),
    ("plugin_wrong", "[murdoch.tasks]\nx = plugin_wrong:KIND\n", "KIND = 42\n",
     "expected a TaskSpec"),
])
def test_a_broken_task_kind_plugin_is_named_in_one_line(site: Path, name: str, entry: str,
                                                       module: str, message: str) -> None:
    _install(site, name, entry, module)
    with pytest.raises(PluginError) as info:
        tk.task_kinds()
    text = str(info.value)
    assert message in text and f"({name} 0.1)" in text and "\n" not in text


def test_an_experiment_plugin_taking_a_built_in_name_is_refused(site: Path) -> None:
    _install(site, "plugin_clash", """
        [murdoch.experiments]
        longterm = plugin_clash:LT
    """, "from experiments.plugins.longterm import LONGTERM as LT\n")
    with pytest.raises(PluginError, match="'longterm' is taken by a built-in one"):
        registry.experiments()


def test_supports_says_what_an_experiment_may_be_used_with() -> None:
    assert "longterm" in registry.supporting("soak") and "boxpush" in registry.supporting(
        "compare")
    assert Supports().soak is False and Supports().allocators is None


@pytest.mark.parametrize("argv", [
    ["-m", "murdoch", "run", "longterm", "--until", "1m"],
    ["-m", "murdoch", "soak", "longterm", "--help"],
    ["-m", "murdoch", "compare", "longterm", "--help"],
    ["-m", "behaviors", "--help"],
])
def test_a_broken_plugin_stops_every_command_with_one_line(tmp_path: Path,
                                                           argv: list[str]) -> None:
    import os
    import subprocess
    import sys

    _install(tmp_path, "plugin_cmd", """
        [murdoch.experiments]
        odd = plugin_cmd:ODD
    """, "ODD = object()\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    out = subprocess.run([sys.executable, *argv], env=env, cwd=tmp_path, capture_output=True,
                         text=True, timeout=120, check=False)
    if argv[1] == "behaviors":  # robots load task kinds only: the experiment is not theirs
        assert out.returncode == 0 and "Traceback" not in out.stderr
        return
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    (line,) = out.stderr.strip().splitlines()
    assert "murdoch.experiments plugin 'odd' = plugin_cmd:ODD (plugin_cmd 0.1)" in line
    assert "expected an experiment `name`" in line
    assert not (tmp_path / "runs").exists()


def test_run_soak_and_compare_offer_every_experiment_that_supports_them() -> None:
    from experiments.compare import compare
    from experiments.run_cli import run
    from experiments.soak.cli import soak

    def choices(command: click.Command) -> list[str]:
        argument = next(p for p in command.params if p.name == "experiment")
        assert isinstance(argument.type, click.Choice)
        return sorted(argument.type.choices)

    every = registry.experiments()
    assert choices(run) == sorted(every)
    assert choices(soak) == sorted(registry.supporting("soak"))
    assert choices(compare) == sorted(registry.supporting("compare"))
    flags = {o for p in run.params for o in getattr(p, "opts", ())}
    for e in every.values():
        assert {o.flag for o in e.options} <= flags, e.name


def test_a_task_lasts_as_its_kind_says_and_takes_place_where_its_kind_says() -> None:
    from experiments.run_tasks import task_spec

    # no duration_s among the task's params: the kind's default, not a KeyError
    tracking = task_spec(PlannedTask(0.0, "object-tracking", {"colour": "#ff0000"}))
    assert (tracking.duration_s, tracking.timeout_s) == (60.0, 660.0)
    given = task_spec(PlannedTask(0.0, "object-tracking", {"colour": "#ff0000",
                                                           "duration_s": 90.0}))
    assert (given.duration_s, given.timeout_s) == (90.0, 690.0)
    goto = task_spec(_goto(0.0))  # its duration is its timeout_s parameter
    assert goto.duration_s == 300.0

    @dataclass(frozen=True)
    class Site:
        camera_xy: tuple[float, float] | None = (4.0, -3.0)

        def colour_xy(self, colour: str) -> tuple[float, float] | None:
            return (1.0, 1.0) if colour == "#00ff00" else None

    kinds = tk.task_kinds()
    assert kinds["monitor-object"].place({}, Site()) == (4.0, -3.0)
    assert kinds["monitor-object"].place({}, Site(camera_xy=None)) is None
    assert kinds["object-tracking"].place({"colour": "#00FF00"}, Site()) == (1.0, 1.0)
    assert kinds["watch-object-side"].place({"x": 2, "y": 5, "colour": "#00ff00"},
                                            Site()) == (2.0, 5.0)
