"""The public allocator API: every registered allocator keeps the contract, broken ones are
named, and the registry names bad plugins in one line."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import pytest

from murdoch.allocators import ALLOCATORS
from murdoch.allocators.registry import BUILTINS, Registry
from murdoch.plugin import (
    CentralAllocator,
    ContractError,
    PluginError,
    RobotView,
    TaskView,
    WorldView,
    check_allocator,
)


@pytest.mark.parametrize("name", list(ALLOCATORS))
def test_every_registered_allocator_keeps_the_contract(name: str) -> None:
    check_allocator(name)


def test_the_registry_loads_every_builtin_without_problems() -> None:
    assert ALLOCATORS.problems == ()
    assert {n for n, _ in BUILTINS} <= set(ALLOCATORS)
    assert all(ALLOCATORS[n].name == n for n in ALLOCATORS)


class Lazy(CentralAllocator):
    name = "lazy"

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        return None


class OneForAll(CentralAllocator):
    """Every task to the first robot it sees, busy or not."""

    name = "one-for-all"

    def assign(self, world: WorldView) -> Mapping[str, str]:
        return {t.id: world.robots[0].name for t in world.tasks}


class Drifting(CentralAllocator):
    """Keeps a count across runs: the same script gets other decisions the second time."""

    name = "drifting"
    calls: ClassVar[list[int]] = [0]

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        self.calls[0] += 1
        return candidates[self.calls[0] % len(candidates)].name


class Raising(CentralAllocator):
    name = "raising"

    def choose(self, task: TaskView, candidates: Sequence[RobotView],
               world: WorldView) -> str | None:
        raise KeyError(task.kind)


@pytest.mark.parametrize(("broken", "rule"), [
    (Lazy, "a task is given to a free capable robot"),
    (OneForAll, "given to a free capable robot|each once"),
    (Drifting, "the same script gives the same decisions"),
    (Raising, "the allocator's code does not raise"),
])
def test_check_allocator_names_the_rule_a_broken_allocator_breaks(
        broken: type[CentralAllocator], rule: str) -> None:
    with pytest.raises(ContractError, match=rule):
        check_allocator(broken)


def test_the_base_class_asks_choose_for_each_open_task_in_arrival_order() -> None:
    robots = (RobotView("a", (0.0, 0.0, 0.0), frozenset({"mobile"}), 0.5, None),
              RobotView("b", (9.0, 0.0, 0.0), frozenset({"mobile"}), None, None),
              RobotView("c", (1.0, 0.0, 0.0), frozenset({"mobile"}), None, "t0"),
              RobotView("d", (1.0, 0.0, 0.0), frozenset(), None, None))
    tasks = (TaskView("t1", "visit", (1.0, 0.0), frozenset({"mobile"}), 3.0),
             TaskView("t2", "visit", (1.0, 0.0), frozenset({"mobile"}), 4.0),
             TaskView("t3", "visit", None, frozenset({"laser"}), 5.0))
    world = WorldView(10.0, tasks, robots)
    assert [r.name for r in world.candidates(tasks[0])] == ["a", "b"]
    assert world.distance(robots[1], tasks[0]) == 8.0 and world.cost(robots[1], tasks[0]) == 16.0
    seen: list[tuple[str, tuple[str, ...]]] = []

    class Nearest(CentralAllocator):
        name = "nearest"

        def choose(self, task: TaskView, candidates: Sequence[RobotView],
                   world: WorldView) -> str | None:
            seen.append((task.id, tuple(r.name for r in candidates)))
            return min(candidates, key=lambda r: world.distance(r, task)).name

    assert Nearest().assign(world) == {"t1": "a", "t2": "b"}
    assert seen == [("t1", ("a", "b")), ("t2", ("b",))]  # t3: nobody capable, not asked
    assert ALLOCATORS["greedy"].user is not None
    from murdoch.allocators.optimal import Optimal

    # greedy gives t1 the nearest robot; the exact assignment minds the total distance
    far = (TaskView("near-a", "visit", (0.0, 0.0), frozenset({"mobile"}), 1.0),
           TaskView("mid", "visit", (4.0, 0.0), frozenset({"mobile"}), 0.0))
    w = WorldView(0.0, (far[1], far[0]), robots[:2])
    assert Optimal().assign(w) == {"near-a": "a", "mid": "b"}


@pytest.mark.parametrize(("value", "expected"), [
    ("no_such_module:Thing", "cannot load no_such_module:Thing: ModuleNotFoundError"),
    ("murdoch.allocators.greedy:Greedy", "is called 'greedy', not 'mine'"),
    ("murdoch.allocators.greedy:Sequence", "expected a CentralAllocator subclass or an Allocator"),
    ("murdoch.plugin:CentralAllocator", "is called '', not 'mine'"),
])
def test_a_bad_plugin_is_named_in_one_line_and_left_out(value: str, expected: str) -> None:
    registry = Registry((("murdoch", BUILTINS[0][1]), ("mine", value)), group=None)
    assert list(registry) == ["murdoch"]
    (problem,) = registry.problems
    assert "\n" not in problem and problem.startswith(f"allocator plugin 'mine' ({value}")
    assert expected in problem
    with pytest.raises(PluginError, match="allocator plugin 'mine'"):
        registry.check()


def test_a_taken_name_and_a_contract_breaker_are_refused() -> None:
    registry = Registry((("greedy", "murdoch.allocators.greedy:Greedy"),
                         ("greedy", "murdoch.allocators.optimal:Optimal"),
                         ("lazy", f"{__name__}:Lazy"),
                         ("Bad Name", "murdoch.allocators.greedy:Greedy")), group=None)
    assert list(registry) == ["greedy", "lazy"]
    assert [p.split(": ", 1)[1] for p in registry.problems] == [
        "the name 'greedy' is already taken",
        "the name must be lowercase letters, digits, '-' or '_'"]


class NoHook(CentralAllocator):
    name = "nohook"


def test_an_allocator_without_a_decision_hook_breaks_the_contract() -> None:
    registry = Registry((("nohook", f"{__name__}:NoHook"),), group=None)
    assert "breaks the contract: it overrides neither choose nor assign" in registry.problems[0]
