"""The referee checker: every registered experiment's referee (the built-ins and the example
package's) keeps the `RunHandle` rules through the scripted run, and a referee that breaks
one is named in one line."""

from __future__ import annotations

import contextlib
import importlib
import itertools
import tomllib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from behaviors import task_kinds as tk
from experiments import registry
from experiments.plugin import (
    ExperimentBase,
    NoReferee,
    PlannedTask,
    Referee,
    RunHandle,
    RunOptions,
)
from experiments.plugin_check import check_experiment
from experiments.referee_check import ScriptedRun, check_referee
from murdoch.plugin import ContractError

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "patrol"


@pytest.fixture
def with_patrol(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The example package as pip would leave it: on sys.path, with its entry points."""
    entry_points = tomllib.loads((EXAMPLE / "pyproject.toml").read_text("utf-8"))[
        "project"]["entry-points"]
    dist = tmp_path / "murdoch_patrol-0.1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: murdoch-patrol\n"
                                   "Version: 0.1.0\n", encoding="utf-8")
    (dist / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items())
        for group, entries in entry_points.items()), encoding="utf-8")
    monkeypatch.syspath_prepend(str(EXAMPLE))
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    tk._installed.cache_clear()
    registry._installed.cache_clear()
    yield
    tk._installed.cache_clear()
    registry._installed.cache_clear()


def test_every_registered_referee_keeps_the_rules_and_the_check_runs_in_check_experiment(
    with_patrol: None,
) -> None:
    names = sorted(registry.experiments())
    assert {"longterm", "boxpush", "patrol"} <= set(names)
    for name in names:
        run = check_referee(name)
        assert run.now > 0 and run.broken is None, name
        check_experiment(name)


def test_the_boxpush_referee_is_driven_through_its_own_fault_actions() -> None:
    run = check_referee("boxpush")
    did = [(a[0], a[1], *a[2:3]) for a in run.actions if a[0] != "record"]
    assert did == [("stop", 40.0, "pusher2"), ("start", 50.0, "pusher2"),
                   ("end", 103.0, "completed")]
    kinds = [a[2] for a in run.actions if a[0] == "record"]
    assert kinds == ["robot_switch_off", "robot_switch_on"]
    assert run.end_reason == "completed" and run.down() == frozenset()


def test_the_scripted_run_answers_from_its_facts_and_keeps_what_was_done() -> None:
    run = ScriptedRun(["b", "a"], ["goto-goal"])
    assert run.robots() == ("a", "b") and run.first_task() is None
    planned = PlannedTask(2.0, "goto-goal", {"x": 1.0, "y": 2.0})
    run.at(2.0)
    run.introduce("t0", planned)
    assert run.first_task() == ("t0", planned) and not run.task_ended("t0")
    run.task_over("t0", "unachievable: nobody")
    assert run.task_ended("t0") and run.unachievable("t0") == "unachievable: nobody"
    run.at(5.0)
    assert run.announce(planned, 5.0) == "r0"
    run.stop_robot("a", 5.0)
    assert run.down() == {"a"}
    run.record(4.0, "my_event", n=1)
    run.withdraw("r0", "changed my mind")
    run.end("completed")
    assert [a[0] for a in run.actions] == ["announce", "stop", "record", "withdraw", "end"]
    assert run.withdrawn == ["r0"] and run.end_reason == "completed"


# -- referees that break a rule ------------------------------------------------------------
def _goto(t: float) -> PlannedTask:
    return PlannedTask(t, "goto-goal", {"x": 1.0, "y": 2.0})


class Acting(NoReferee):
    """A referee that does `act(loop, now)` in its after_tasks at 12 s."""

    def __init__(self, act: Callable[[RunHandle, float], None],
                 own: Mapping[str, Callable[[str, float], None]] | None = None) -> None:
        self.act, self.own = act, own or {}
        self.loop: RunHandle | None = None

    def bind(self, loop: RunHandle) -> None:
        self.loop = loop

    def fault_actions(self) -> Mapping[str, Callable[[str, float], None]]:
        return self.own

    def after_tasks(self, now: float) -> None:
        if now == 12.0 and self.loop is not None:
            self.act(self.loop, now)


@dataclass(frozen=True)
class Refereed(ExperimentBase):
    """goto-goal tasks every 4 s, watched by `make()`."""

    make: Callable[[], Referee] = NoReferee

    def tasks(self, spec: Any, options: RunOptions) -> Iterator[PlannedTask | None]:
        return (_goto(2.0 + 4.0 * i) for i in itertools.count())

    def referee(self, spec: Any, options: RunOptions) -> Referee:
        return self.make()


def _refereed(act: Callable[[RunHandle, float], None], **own: Callable[[str, float], None]
              ) -> Refereed:
    return Refereed("refereed", "simple", task_kinds=("goto-goal",),
                    make=lambda: Acting(act, own))


def _ignore(_: object) -> None:
    pass


def _boom(*_: Any) -> None:
    raise RuntimeError("boom\nsecond line")


def _swallowed(loop: RunHandle, now: float) -> None:
    with contextlib.suppress(Exception):  # a referee that hides the refusal is named
        loop.end("")


def _drifting() -> Callable[[RunHandle, float], None]:
    """Records a number that differs from one pass of the script to the next."""
    passes = itertools.count()
    return lambda loop, now: loop.record(now, "my_event", n=next(passes) % 2)


BROKEN: list[tuple[str, Refereed]] = [
    ("after_tasks at 12 s raised RuntimeError: boom", _refereed(_boom)),
    ("announce(): task kind 'object-tracking' is not one of its task_kinds (goto-goal)",
     _refereed(lambda loop, now: _ignore(loop.announce(
         PlannedTask(now, "object-tracking", {"colour": "#ff0000"}), now)))),
    ("announce(): now=3.0, but the hook was called at 12 s",
     _refereed(lambda loop, now: _ignore(loop.announce(_goto(now), 3.0)))),
    ("end(): the reason must be a non-empty str, found ''",
     _refereed(lambda loop, now: loop.end(""))),
    ("end(): the reason must be a non-empty str, found ''", _refereed(_swallowed)),
    ("record('my_event'): field 'where' is not a JSON value (set)",
     _refereed(lambda loop, now: loop.record(now, "my_event", where={1, 2}))),
    ("record('my_event'): field 'level' is not a JSON value (float)",
     _refereed(lambda loop, now: loop.record(now, "my_event", level=float("nan")))),
    ("record('task_outcome'): the runner writes the task_outcome events",
     _refereed(lambda loop, now: loop.record(now, "task_outcome", task="t0"))),
    ("record('my_event'): t_s=13.0, expected a time from 0 to now (12 s)",
     _refereed(lambda loop, now: loop.record(now + 1.0, "my_event"))),
    ("withdraw(): no task 'nope' was introduced",
     _refereed(lambda loop, now: loop.withdraw("nope", "why not"))),
    ("stop_robot(): no robot 'robot9' (robots: robot1)",
     _refereed(lambda loop, now: loop.stop_robot("robot9", now))),
    ("set_closing_reason(): the reason must be a non-empty str, found ' '",
     _refereed(lambda loop, now: loop.set_closing_reason(" "))),
    ("fault action 'kill' is the runner's own",
     _refereed(lambda loop, now: None, kill=lambda robot, now: None)),
    ("fault action 'jam' at 40 s raised RuntimeError: boom",
     _refereed(lambda loop, now: None, jam=_boom)),
    ("it must do the same in the same scripted run (no clocks, no global random numbers); "
     "at 12 s it did record my_event 12.0 [('n', 0)], then record my_event 12.0 [('n', 1)]",
     _refereed(_drifting())),
]


@pytest.mark.parametrize(("message", "experiment"), BROKEN,
                         ids=[f"{i}-{m.split(':')[0][:30]}" for i, (m, _) in enumerate(BROKEN)])
def test_a_referee_that_breaks_a_rule_is_named_in_one_line(message: str,
                                                           experiment: Refereed) -> None:
    with pytest.raises(ContractError) as info:
        check_referee(experiment)
    assert str(info.value) == f"experiment 'refereed': referee: {message}"
    with pytest.raises(ContractError) as again:
        check_experiment(experiment)
    assert str(again.value) == str(info.value) and "\n" not in str(again.value)


def test_a_referee_that_keeps_the_rules_passes_and_its_actions_are_kept() -> None:
    def act(loop: RunHandle, now: float) -> None:
        first = loop.first_task()
        assert first is not None and first[0] == "t0"
        task = loop.announce(_goto(now), now)
        loop.withdraw(task, "not needed after all")
        loop.record(now, "my_event", first=first[0], down=sorted(loop.down()))
        loop.end("completed")

    run = check_referee(_refereed(act))
    assert [a[0] for a in run.actions] == ["announce", "withdraw", "record", "end"]
    assert run.now == 12.0 and run.end_reason == "completed"
