"""The commands of the README and of the docs work as written.

Every fenced ``sh`` block of README.md and of each page of docs/ runs, in order (each file in
its own scratch directory, its blocks one after the other), in a directory holding the
checkout's ``.venv`` (activated by the block's own ``source .venv/bin/activate`` or, for the
blocks after it, by the environment) and ``worlds``. An HTML comment just before a block
adjusts it for the test: ``<!-- readme-test: skip (why) -->`` leaves it out;
``<!-- readme-test: replace OLD => NEW -->`` shortens a command. ``$FREE_PORT`` is a base port
whose run of neighbours nothing listens on either.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from sibling import load_sibling

free_ports = load_sibling(__file__, "free_ports.py")

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"
GUIDE = REPO / "docs" / "extending.md"
"""The tutorial installs packages, so it runs in a venv of its own: test_plugin_package.py."""


def _runnable(page: Path) -> bool:
    return any(b.skip is None for b in sh_blocks(page.read_text(encoding="utf-8")))



pytestmark = pytest.mark.timeout(900)

_FENCE = re.compile(r"^```(\S*)\s*$")
_DIRECTIVE = re.compile(r"^<!--\s*readme-test:\s*(.*?)\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    line: int
    text: str
    skip: str | None
    replacements: tuple[tuple[str, str], ...]

    def script(self) -> str:
        text = self.text
        for old, new in self.replacements:
            if old not in text:
                raise AssertionError(f"README line {self.line}: {old!r} is not in the block")
            text = text.replace(old, new)
        return text


def sh_blocks(markdown: str) -> list[Block]:
    """The fenced sh blocks with the directives just above each."""
    lines = markdown.splitlines()
    blocks: list[Block] = []
    pending: list[str] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        directive = _DIRECTIVE.match(lines[i])
        if directive:
            pending.append(directive.group(1))
        elif m:
            lang, start = m.group(1), i
            i += 1
            body = []
            while i < len(lines) and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            if lang == "sh":
                skip = next((d[4:].strip() or "skipped" for d in pending
                             if d.startswith("skip")), None)
                reps = []
                for d in pending:
                    if d.startswith("replace "):
                        old, sep, new = d[len("replace "):].partition(" => ")
                        assert sep, f"README line {start}: bad directive {d!r}"
                        reps.append((old, new))
                blocks.append(Block(start + 1, "\n".join(body) + "\n", skip, tuple(reps)))
            pending = []
        elif lines[i].strip():
            pending = []  # a directive belongs to the block right below it
        i += 1
    return blocks


def test_directives_are_parsed() -> None:
    md = ("<!-- readme-test: skip (slow) -->\n```sh\nmake run\n```\n\ntext\n"
          "<!-- readme-test: replace 1h => 1m -->\n```sh\nmurdoch run x --until 1h\n```\n"
          "```text\nnot run\n```\n")
    blocks = sh_blocks(md)
    assert [b.skip for b in blocks] == ["(slow)", None]
    assert blocks[1].script() == "murdoch run x --until 1m\n"


ALL_PAGES = [README, *sorted(p for p in (REPO / "docs").glob("*.md") if p != GUIDE)]
PAGES = [p for p in ALL_PAGES if _runnable(p)]
"""The pages with a command block to run (the others hold only examples and listings)."""


def test_the_pages_hold_runnable_blocks() -> None:
    blocks = [b for page in ALL_PAGES for b in sh_blocks(page.read_text(encoding="utf-8"))]
    assert len([b for b in blocks if b.skip is None]) >= 8


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(REPO).as_posix() for p in PAGES])
def test_every_command_block_runs(page: Path, tmp_path: Path) -> None:
    venv = Path(sys.executable).parent.parent
    blocks = sh_blocks(page.read_text(encoding="utf-8"))
    work = tmp_path / "clone"
    work.mkdir()
    (work / ".venv").symlink_to(venv)
    (work / "worlds").symlink_to(REPO / "worlds")
    env = dict(os.environ)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(venv)
    env.pop("PYTHONPATH", None)
    for block in blocks:
        if block.skip is not None:
            continue
        env["FREE_PORT"] = str(free_ports.free_port_block())
        script = "set -e\n" + block.script()
        proc = subprocess.run(["bash", "-c", script], cwd=work, env=env, capture_output=True,
                              text=True, timeout=600, stdin=subprocess.DEVNULL)
        assert proc.returncode == 0, (
            f"{page.name} block at line {block.line} failed ({proc.returncode}):\n{script}\n"
            f"--- stdout\n{proc.stdout[-3000:]}\n--- stderr\n{proc.stderr[-3000:]}")
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
