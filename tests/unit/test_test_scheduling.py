"""The order in which `make test` hands scopes to its workers (tests/scheduling.py)."""

from __future__ import annotations

import json
from pathlib import Path

import scheduling


def test_costliest_scope_first_and_a_scope_stays_together() -> None:
    ids = ["tests/unit/test_a.py::t1", "tests/unit/test_a.py::t2",
           "tests/integration/test_b.py::t1", "tests/integration/test_b.py::t2",
           "tests/unit/test_c.py::K::t1", "tests/unit/test_d.py::t1"]
    costs = {"tests/integration/test_b.py": 90.0, "tests/unit/test_c.py::K": 5.0}
    order = [ids[i] for i in scheduling.costliest_first(ids, costs)]
    assert order == [ids[2], ids[3], ids[4], ids[0], ids[1], ids[5]]


def test_split_modules_give_each_test_its_own_scope() -> None:
    page = "tests/integration/test_readme.py::test_every_command_block_runs[docs/runs.md]"
    assert scheduling.scope_of(page) == page
    assert scheduling.scope_of("tests/unit/test_x.py::test_y[1]") == "tests/unit/test_x.py"
    assert scheduling.scope_of("tests/unit/test_x.py::K::test_y") == "tests/unit/test_x.py::K"
    other = "tests/integration/test_readme.py::test_every_command_block_runs[README.md]"
    costs = {other: 10.0, page: 50.0}
    assert scheduling.costliest_first([other, page], costs) == [1, 0]


def test_no_or_unreadable_costs_keep_the_collection_order(tmp_path: Path) -> None:
    assert scheduling.load_costs(tmp_path / "missing.json") == {}
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2", encoding="utf-8")
    assert scheduling.load_costs(bad) == {}
    good = tmp_path / "good.json"
    good.write_text(json.dumps({"tests/unit/test_a.py": 3}), encoding="utf-8")
    assert scheduling.load_costs(good) == {"tests/unit/test_a.py": 3.0}
    assert scheduling.costliest_first(["a::1", "b::1", "a::2"], {}) == [0, 2, 1]


def test_the_recorded_costs_name_scopes_of_this_suite() -> None:
    """A renamed or deleted module must not linger in the table."""
    repo = Path(scheduling.__file__).resolve().parent.parent
    for scope in scheduling.load_costs():
        assert (repo / scope.split("::", 1)[0]).is_file(), scope
