"""Loading another test module by path (test directories are not packages)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType


def load_sibling(anchor: str, filename: str) -> ModuleType:
    """The module `filename` next to the file `anchor` (pass ``__file__``), freshly executed
    under a private name so that it never clashes with the copy pytest collects."""
    path = Path(anchor).with_name(filename)
    spec = importlib.util.spec_from_file_location(f"_sibling_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
