"""The shipped packages stay within their size limits (`tools/code_size.py`)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

_TOOL = Path(__file__).resolve().parents[2] / "tools" / "code_size.py"


def _tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location("code_size", _TOOL)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (its dataclasses look their module up)
    spec.loader.exec_module(module)
    return module


def test_no_module_class_or_function_is_over_its_limit() -> None:
    tool = _tool()
    found = tool.spans()
    assert {s.kind for s in found} == {"module", "class", "function"}
    assert tool.violations(found) == []


def test_the_checker_reports_what_is_too_long(tmp_path: Path) -> None:
    tool = _tool()
    pkg = tmp_path / "murdoch"
    pkg.mkdir()
    body = "\n".join(f"    x{i} = {i}" for i in range(130))
    methods = "\n".join(f"    def m{i}(self) -> None:\n        pass\n" for i in range(160))
    (pkg / "big.py").write_text(f"def long() -> None:\n{body}\n\n\nclass Wide:\n{methods}\n")
    found = tool.spans(tmp_path)
    broken = tool.violations(found)
    assert any("function murdoch/big.py::long has 131 lines" in b for b in broken)
    assert any("class murdoch/big.py::Wide" in b for b in broken)
    assert any("module murdoch/big.py" in b for b in broken)
