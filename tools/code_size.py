"""Size limits of the shipped packages: modules, classes and functions that stay readable.

`python tools/code_size.py` prints the measures and the largest offenders and exits non-zero
when a limit is broken; `tests/unit/test_code_size.py` runs the same check.
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("player_server", "behaviors", "murdoch", "worlds", "experiments")

MAX_MODULE_LINES = 600
MAX_CLASS_LINES = 450
MAX_FUNCTION_LINES = 120
LONG_FUNCTION_LINES = 100
MAX_LONG_FUNCTIONS = 3

@dataclass(frozen=True)
class Span:
    kind: str  # "module", "class" or "function"
    name: str  # path, or path::qualified.name
    lines: int


def spans(root: Path = ROOT) -> list[Span]:
    """Every module, class and function (methods and nested ones too) with its line count."""
    out: list[Span] = []
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            text = path.read_text(encoding="utf-8")
            out.append(Span("module", rel, len(text.splitlines())))
            _walk(ast.parse(text, filename=rel), rel, "", out)
    return out


def _walk(node: ast.AST, rel: str, prefix: str, out: list[Span]) -> None:
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            kind = "class" if isinstance(child, ast.ClassDef) else "function"
            # from the def (or class) line to the last line of the body; decorators (a
            # command's options, say) do not count
            first = child.lineno
            last = child.end_lineno or child.lineno
            name = f"{prefix}{child.name}"
            out.append(Span(kind, f"{rel}::{name}", last - first + 1))
            _walk(child, rel, f"{name}.", out)
        else:
            _walk(child, rel, prefix, out)


def violations(found: list[Span]) -> list[str]:
    """The broken limits, one sentence each (empty when every limit holds)."""
    limits = {"module": MAX_MODULE_LINES, "class": MAX_CLASS_LINES,
              "function": MAX_FUNCTION_LINES}
    out = [f"{s.kind} {s.name} has {s.lines} lines (at most "
           f"{limits[s.kind]})"
           for s in found if s.lines > limits[s.kind]]
    long = [s for s in found if s.kind == "function" and s.lines >= LONG_FUNCTION_LINES]
    if len(long) > MAX_LONG_FUNCTIONS:
        names = ", ".join(f"{s.name} ({s.lines})" for s in long)
        out.append(f"{len(long)} functions of {LONG_FUNCTION_LINES}+ lines "
                   f"(at most {MAX_LONG_FUNCTIONS}): {names}")
    return out


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    root = Path(args[0]).resolve() if args else ROOT  # another checkout, to compare
    found = spans(root)
    for kind in ("module", "class", "function"):
        top = sorted((s for s in found if s.kind == kind), key=lambda s: -s.lines)[:5]
        print(f"largest {kind}s: " + ", ".join(f"{s.name} ({s.lines})" for s in top))
    broken = violations(found)
    for line in broken:
        print("LIMIT:", line)
    print("all size limits hold" if not broken else f"{len(broken)} limit(s) broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
