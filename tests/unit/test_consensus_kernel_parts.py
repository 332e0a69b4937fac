"""The compiled runs are built against the kernel parts they name.

numba caches a compiled function by its own file; a kernel that calls into another kernel
module would keep running code built from that module's old version. Each kernel module names
the fingerprint of every kernel file it calls into, so a change to a part must change the
files that use it as well (and numba recompiles them).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import numpy as np

from murdoch.consensus import kernel_parts
from murdoch.consensus.conflict import NONE, Action, resolve, rule_arrays

_TOOL = Path(__file__).resolve().parents[2] / "tools" / "kernel_fingerprints.py"


def _tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location("kernel_fingerprints", _TOOL)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_each_kernel_names_current_fingerprints_of_every_kernel_it_uses() -> None:
    tool = _tool()
    assert tool.stale() == [], "run tools/kernel_fingerprints.py"
    kernels = set(tool.ORDER)
    named: dict[str, set[str]] = {}
    for name in tool.ORDER:
        text = (tool.KERNELS / name).read_text()
        imported = {f"{m}.py" for m in re.findall(r"^from murdoch\.consensus\.(\w+) import",
                                                     text, re.M)} & kernels
        named[name] = {dep for dep, _ in tool._ENTRY.findall(text)}
        # every kernel file it imports, and every one those name in turn
        wanted = set(imported)
        for dep in imported:
            wanted |= named[dep]
        assert named[name] == wanted, name


def test_the_compiled_conflict_rule_agrees_with_the_reference_everywhere() -> None:
    table, lut = rule_arrays()
    rng = np.random.default_rng(5)
    n = 4
    for _ in range(3000):
        i, k = (int(v) for v in rng.choice(n, 2, replace=False))
        zi, zk = (int(v) for v in rng.integers(-1, n, 2))
        yi, yk = (float(v) for v in rng.choice([0.0, 1.0, 2.0], 2))
        s = np.append(rng.choice([0.0, 1.0, 2.0], n), -np.inf)
        s_k = np.append(rng.choice([0.0, 1.0, 2.0], n), -np.inf)
        got = kernel_parts.conflict_action(i, k, yi, zi, yk, zk, s, s_k, table, lut)
        s_i_map = {q: float(s[q]) for q in range(n)}
        s_k_map = {q: float(s_k[q]) for q in range(n)}
        want, _rule = resolve(i, k, yk, zk, yi, zi, s_k_map, s_i_map)
        assert Action(got) == want, (i, k, yi, zi, yk, zk, s, s_k)
    assert NONE == kernel_parts.NONE
