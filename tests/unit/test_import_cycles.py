"""The import-circle check: it names a circle, counts type-checking imports, and finds none
in the shipped packages."""

from __future__ import annotations

import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import import_cycles


def _write(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))


@pytest.fixture
def tiny(tmp_path: Path) -> Iterator[Path]:
    """A package `tinycirc`: a -> b -> (under TYPE_CHECKING) a, and c -> a (no circle)."""
    _write(tmp_path, {
        "tinycirc/__init__.py": "",
        "tinycirc/a.py": "from tinycirc import b\n",
        "tinycirc/b.py": """
            from typing import TYPE_CHECKING
            if TYPE_CHECKING:
                from tinycirc.a import thing
            """,
        "tinycirc/c.py": "import tinycirc.a\n",
        "tinyclean/__init__.py": "",
        "tinyclean/x.py": "from tinyclean import y\n",
        "tinyclean/y.py": "import os\n",
    })
    sys.path.insert(0, str(tmp_path))
    try:
        yield tmp_path
    finally:
        sys.path.remove(str(tmp_path))
        for name in [m for m in sys.modules if m.startswith(("tinycirc", "tinyclean"))]:
            del sys.modules[name]


def test_a_circle_through_a_type_checking_import_is_named(tiny: Path) -> None:
    lines, failing = import_cycles.report(import_cycles.import_graph(["tinycirc"]))
    assert failing
    assert lines == ["import circle of 2 modules: tinycirc.a -> tinycirc.b -> tinycirc.a"]


def test_a_package_without_circles_passes(tiny: Path) -> None:
    assert import_cycles.report(import_cycles.import_graph(["tinyclean"])) == ([], False)


def test_a_tolerated_package_is_reported_without_failing(tiny: Path) -> None:
    graph = import_cycles.import_graph(["tinycirc", "tinyclean"])
    lines, failing = import_cycles.report(graph, tolerate=["tinycirc"])
    assert not failing and lines[0].startswith("tolerated import circle of 2 modules")
    assert import_cycles.report(graph, tolerate=["tinyclean"])[1]


def test_components_are_found_in_a_plain_graph() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}, "f": {"d"}}
    assert import_cycles.circles(graph) == [["a", "b", "c"], ["e"]]
    assert import_cycles.cycle_through(graph, ["a", "b", "c"]) == ["a", "b", "c", "a"]


def test_the_shipped_packages_outside_experiments_have_no_circles() -> None:
    graph = import_cycles.import_graph(["player_server", "behaviors", "murdoch", "worlds"])
    assert import_cycles.report(graph) == ([], False)
