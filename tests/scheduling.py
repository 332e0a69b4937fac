"""How `make test` shares the suite between its two workers: the costliest work first.

pytest-xdist's ``--dist loadscope`` hands out *scopes* (a test module, or a class in one) and
keeps each on one worker, so a run its tests share through a module-scoped fixture is made
once. Left to itself it hands out the scopes with the most tests first, which puts the
end-to-end modules (one to three tests of a minute or more each) last, where the one that
is started last decides when the suite ends. Here the scopes are handed out by what they
cost, the costliest first (longest processing time first), from ``scope_costs.json``:
seconds per scope measured on the 2-core machine, refreshed with

    pytest -n 2 --dist loadscope --record-scope-costs

A scope the file does not know comes after the known ones, in collection order. The modules
in ``SPLIT`` share nothing between their tests (no module fixture), so each of their tests
is a scope of its own and the two workers can share them.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

COSTS_FILE = Path(__file__).with_name("scope_costs.json")

#: modules whose tests are independent runs (each test its own scope)
SPLIT = frozenset({"tests/integration/test_readme.py"})


def scope_of(nodeid: str) -> str:
    """The unit of work a node id belongs to (xdist's loadscope rule, with SPLIT)."""
    if nodeid.split("::", 1)[0] in SPLIT:
        return nodeid
    return nodeid.rsplit("::", 1)[0]


def load_costs(path: Path = COSTS_FILE) -> dict[str, float]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return {str(k): float(v) for k, v in data.items()} if isinstance(data, dict) else {}


def costliest_first(nodeids: list[str], costs: Mapping[str, float]) -> list[int]:
    """Indices of `nodeids` ordered by their scope's cost, highest first; a scope's tests
    stay together and in their order, unknown scopes last in their order."""
    first: dict[str, int] = {}
    for i, n in enumerate(nodeids):
        first.setdefault(scope_of(n), i)

    def key(i: int) -> tuple[float, int, int]:
        scope = scope_of(nodeids[i])
        return (-costs.get(scope, 0.0), first[scope], i)

    return sorted(range(len(nodeids)), key=key)


class _Recorder:
    """Sums each scope's setup, call and teardown time as the reports arrive."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.seconds: dict[str, float] = defaultdict(float)

    @pytest.hookimpl
    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        self.seconds[scope_of(report.nodeid)] += report.duration

    @pytest.hookimpl
    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if hasattr(session.config, "workerinput"):
            return  # the controller writes what all workers reported
        costs = {k: round(v, 1) for k, v in sorted(self.seconds.items(), key=lambda kv: -kv[1])
                 if v >= 1.0}
        self.path.write_text(json.dumps(costs, indent=1) + "\n", encoding="utf-8")


def add_options(parser: pytest.Parser) -> None:
    parser.addoption("--record-scope-costs", action="store_true",
                     help=f"write each scope's seconds to {COSTS_FILE.name} at the end")


def configure(config: pytest.Config) -> None:
    if config.getoption("--record-scope-costs"):
        config.pluginmanager.register(_Recorder(COSTS_FILE), "murdoch-scope-costs")


def order(items: list[pytest.Item]) -> None:
    costs = load_costs()
    if not costs:
        return
    ids = [item.nodeid for item in items]
    items[:] = [items[i] for i in costliest_first(ids, costs)]


def make_scheduler(config: pytest.Config, log: Any) -> Any:
    """xdist's loadscope scheduler with SPLIT scopes, handing scopes out in collection
    order (which `order` made costliest first)."""
    from xdist.scheduler import LoadScopeScheduling

    class _CostliestFirst(LoadScopeScheduling):  # type: ignore[misc]
        def _split_scope(self, nodeid: str) -> str:
            return scope_of(nodeid)

    config.option.loadscopereorder = False
    return _CostliestFirst(config, log)
