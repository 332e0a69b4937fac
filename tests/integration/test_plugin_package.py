"""A plugin package installed by pip into a fresh virtualenv: its names appear in every
command, its experiment runs end to end with its allocator and task kind, and a broken
plugin stops a run with one line.

One virtualenv per module (`plugin_venv`): the project installed editable with its
dependencies from the configured package indexes (by uv, as `make` installs it), then
``examples/patrol`` (a real ``pip install``, entry points and all). Nothing of the project's
own virtualenv is visible in it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "patrol"

pytestmark = pytest.mark.timeout(1800)


def _run(args: list[str], *, env: dict[str, str], cwd: Path | None = None,
         timeout: float = 900) -> subprocess.CompletedProcess[str]:
    return subprocess.run(args, env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL, check=False)


def _env(venv: Path) -> dict[str, str]:
    # (bytecode is written, so each module the venv's processes import is compiled once, by
    # the first of them: far less than compiling every installed module up front)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONDONTWRITEBYTECODE")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(venv)
    return env


@pytest.fixture(scope="module")
def plugin_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    venv = tmp_path_factory.mktemp("plugin") / "venv"
    made = _run([sys.executable, "-m", "venv", str(venv)], env=dict(os.environ), timeout=300)
    assert made.returncode == 0, made.stderr
    env = _env(venv)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q",
           "--disable-pip-version-check"]
    uv = Path(sys.executable).parent / "uv"  # the project's own virtualenv has it (make)
    project = _run([str(uv), "pip", "install", "-q", "--python",
                    str(venv / "bin" / "python"),
                    "-c", str(REPO / "constraints.txt"), "-e", str(REPO)], env=env,
                   timeout=1500)
    assert project.returncode == 0, project.stderr[-3000:]
    example = _run([*pip, str(EXAMPLE)], env=env, timeout=600)
    assert example.returncode == 0, example.stderr[-3000:]
    return venv


def test_the_venv_sees_only_what_was_installed_into_it(plugin_venv: Path) -> None:
    probe = _run([str(plugin_venv / "bin" / "python"), "-c",
                  "import sys, murdoch_patrol, murdoch_api; print(sys.prefix); "
                  "print(murdoch_patrol.__file__)"], env=_env(plugin_venv))
    assert probe.returncode == 0, probe.stderr
    prefix, where = probe.stdout.split()
    assert Path(prefix) == plugin_venv and Path(where).is_relative_to(plugin_venv)


def test_every_command_lists_the_plugins_names(plugin_venv: Path) -> None:
    env = _env(plugin_venv)
    for command in ("run", "soak", "compare"):
        out = _run(["murdoch", command, "--help"], env=env)
        assert out.returncode == 0, out.stderr
        assert "patrol" in out.stdout and "--waypoints-per-route" in out.stdout, command
    run_help = _run(["murdoch", "run", "--help"], env=env).stdout
    assert "nearest-patroller" in run_help
    robot_help = _run(["murdoch-robot", "--help"], env=env).stdout
    assert "patrol-waypoints" in robot_help


def test_the_patrol_experiment_runs_with_its_allocator_and_completes_tasks(
    plugin_venv: Path, tmp_path: Path,
) -> None:
    out = _run(["murdoch", "run", "patrol", "--allocator", "nearest-patroller", "--until", "4m",
                "--task-interval", "30", "--patrol-s", "40", "--out", str(tmp_path),
                "--no-replay", "--no-record"], env=_env(plugin_venv), timeout=1200)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    (run_dir,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    config = json.loads((run_dir / "config.json").read_text(encoding="utf-8"))
    assert config["allocator"] == "nearest-patroller" and config["patrol_s"] == 40.0
    done = summary["tasks"]["by_kind"]["patrol-waypoints"]
    assert done.get("completed", 0) >= 2, summary["tasks"]


def test_the_example_keeps_the_contract_its_referee_included(plugin_venv: Path) -> None:
    out = _run([str(plugin_venv / "bin" / "python"), "-c",
                "from murdoch_api import check_experiment, check_referee\n"
                "check_experiment('patrol'); print(check_referee('patrol').actions)"],
               env=_env(plugin_venv))
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip() == "[]"  # it has no referee of its own: nothing done


def test_a_broken_plugin_is_named_in_one_line_and_nothing_starts(
    plugin_venv: Path, tmp_path: Path,
) -> None:
    site = next((plugin_venv / "lib").glob("python*/site-packages"))
    dist = site / "broken_plugin-0.1.dist-info"
    dist.mkdir()
    try:
        (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\n"
                                       "Version: 0.1\n", encoding="utf-8")
        (dist / "entry_points.txt").write_text(
            "[murdoch.tasks]\nbroken = no_such_module.kinds:KIND\n", encoding="utf-8")
        env = _env(plugin_venv)
        for args in (["murdoch", "run", "patrol", "--until", "1m", "--out", str(tmp_path)],
                     ["murdoch-robot", "--help"]):
            out = _run(args, env=env, timeout=120)
            assert out.returncode == 2, (args, out.stdout, out.stderr)
            assert "Traceback" not in out.stderr
            (line,) = out.stderr.strip().splitlines()
            assert "murdoch.tasks plugin 'broken'" in line and "(broken-plugin 0.1)" in line
            assert "No module named 'no_such_module'" in line
        assert not any(tmp_path.iterdir())
    finally:
        shutil.rmtree(dist)


# -- docs/extending.md, as written -----------------------------------------------------------
GUIDE = REPO / "docs" / "extending.md"
_FENCE = re.compile(r"^```(\S*)\s*$")
_DIRECTIVE = re.compile(r"^<!--\s*(extending|readme)-test:\s*(.*?)\s*-->\s*$")


@dataclass(frozen=True)
class GuideBlock:
    line: int
    lang: str
    text: str
    directives: tuple[str, ...]

    def target(self) -> tuple[str, str] | None:
        """('file' or 'append', path) of a block that is a file of the package."""
        for d in self.directives:
            verb, _, path = d.partition(" ")
            if verb in ("file", "append"):
                return verb, path.strip()
        return None

    def script(self) -> str | None:
        """The shell script of an sh block (None: skipped), its replacements made."""
        if any(d.startswith("skip") for d in self.directives):
            return None
        text = self.text
        for d in self.directives:
            if d.startswith("replace "):
                old, sep, new = d[len("replace "):].partition(" => ")
                assert sep and old in text, f"extending.md line {self.line}: {d!r}"
                text = text.replace(old, new)
        return text


def guide_blocks(markdown: str) -> list[GuideBlock]:
    lines = markdown.splitlines()
    blocks: list[GuideBlock] = []
    pending: list[str] = []
    i = 0
    while i < len(lines):
        fence, directive = _FENCE.match(lines[i]), _DIRECTIVE.match(lines[i])
        if directive:
            pending.append(directive.group(2))
        elif fence:
            start, body = i, []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            blocks.append(GuideBlock(start + 1, fence.group(1), "\n".join(body) + "\n",
                                     tuple(pending)))
            pending = []
        elif lines[i].strip():
            pending = []
        i += 1
    return blocks


def test_every_code_block_of_the_guide_is_a_file_or_a_command() -> None:
    blocks = guide_blocks(GUIDE.read_text(encoding="utf-8"))
    for b in blocks:
        if b.lang in ("python", "toml"):
            assert b.target() is not None, f"extending.md line {b.line}: which file is it?"
        else:
            assert b.lang in ("sh", "text"), f"extending.md line {b.line}: {b.lang!r}"
    assert sum(b.lang == "sh" and b.script() is not None for b in blocks) >= 5


def test_the_guide_runs_as_written(plugin_venv: Path, tmp_path: Path) -> None:
    work = tmp_path / "checkout"
    work.mkdir()
    (work / ".venv").symlink_to(plugin_venv)
    env = _env(plugin_venv)
    for block in guide_blocks(GUIDE.read_text(encoding="utf-8")):
        target = block.target()
        if target is not None:
            verb, path = target
            file = work / path
            file.parent.mkdir(parents=True, exist_ok=True)
            with file.open("a" if verb == "append" else "w", encoding="utf-8") as f:
                f.write(block.text)
            continue
        script = block.script() if block.lang == "sh" else None
        if script is None:
            continue
        proc = subprocess.run(["bash", "-c", "set -e\n" + script], cwd=work, env=env,
                              capture_output=True, text=True, timeout=900,
                              stdin=subprocess.DEVNULL)
        assert proc.returncode == 0, (
            f"extending.md block at line {block.line} failed ({proc.returncode}):\n{script}\n"
            f"--- stdout\n{proc.stdout[-3000:]}\n--- stderr\n{proc.stderr[-3000:]}")
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    runs = [p for p in (work / "runs" / "tutorial").iterdir() if p.is_dir()]
    corners = [p for p in runs if p.name.startswith("corners")]
    assert corners, runs
    summary = json.loads((corners[0] / "summary.json").read_text(encoding="utf-8"))
    assert summary["tasks"]["by_kind"]["visit"].get("completed", 0) >= 1, summary["tasks"]
