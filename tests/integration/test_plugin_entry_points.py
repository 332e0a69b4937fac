"""Allocators from installed packages: the entry-point group `murdoch.allocators` extends the
registry of every command, and a broken plugin stops a run with one line naming it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(300)

GOOD = '''
from murdoch.plugin import CentralAllocator


class Farthest(CentralAllocator):
    name = "farthest"
    summary = "each open task to the farthest free robot"

    def choose(self, task, candidates, world):
        return max(candidates, key=lambda r: (world.distance(r, task), r.name)).name
'''


def _install(site: Path, dist: str, module: str, source: str, entries: dict[str, str]) -> None:
    """What pip leaves behind: a module and its distribution's metadata with entry points."""
    (site / f"{module}.py").write_text(source)
    info = site / f"{dist}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
    lines = "".join(f"{name} = {value}\n" for name, value in entries.items())
    (info / "entry_points.txt").write_text(f"[murdoch.allocators]\n{lines}")


def _run(site: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(site))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True,
                          timeout=120, check=False, env=env)


def test_an_installed_allocator_is_listed_and_checked(tmp_path: Path) -> None:
    _install(tmp_path, "farthest_alloc", "farthest_alloc", GOOD,
             {"farthest": "farthest_alloc:Farthest"})
    helped = _run(tmp_path, "-m", "murdoch", "run", "--help")
    assert helped.returncode == 0 and "farthest" in helped.stdout
    checked = _run(tmp_path, "-c", "from murdoch.plugin import check_allocator; "
                   "check_allocator('farthest'); print('kept')")
    assert checked.returncode == 0 and checked.stdout.strip() == "kept", checked.stderr


@pytest.mark.parametrize(("source", "entries", "says"), [
    ("raise ImportError('needs a library that is not here')\n",
     {"broken": "broken_alloc:Thing"}, "cannot load broken_alloc:Thing: ImportError"),
    (GOOD, {"greedy": "broken_alloc:Farthest"}, "the name 'greedy' is already taken"),
    ("from murdoch.plugin import CentralAllocator\n\n\nclass Thing(CentralAllocator):\n"
     "    name = 'thing'\n", {"thing": "broken_alloc:Thing"},
     "breaks the contract: it overrides neither choose nor assign"),
])
def test_a_broken_plugin_stops_every_command_with_one_line(
        tmp_path: Path, source: str, entries: dict[str, str], says: str) -> None:
    _install(tmp_path, "broken_alloc", "broken_alloc", source, entries)
    (name,) = entries
    for args in (["-m", "murdoch", "run", "longterm", "--until", "10s",
                  "--out", str(tmp_path / "runs")],
                 ["-m", "murdoch", "compare", "longterm", "--allocators", "murdoch",
                  "--seeds", "1", "--until", "10s", "--out", str(tmp_path / "cmp")],
                 ["-m", "behaviors", "--name", "r1", "--port", "6665"]):
        proc = _run(tmp_path, *args)
        assert proc.returncode == 2, (args, proc.stdout, proc.stderr)
        assert "Traceback" not in proc.stderr
        (line,) = [ln for ln in proc.stderr.splitlines() if f"allocator plugin '{name}'" in ln]
        assert says in line and "from broken_alloc" in line
    assert not (tmp_path / "runs").exists() and not (tmp_path / "cmp").exists()
