"""The compiled runs are built against the shared kernel parts they name.

numba caches a compiled function by its own file; a kernel that calls `kernel_parts` would
keep running code built from the old parts after they change. Each kernel module names the
fingerprint of the parts it was written against, so a change to the parts must change the
kernel files as well (and numba recompiles them).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from murdoch.consensus import (
    cbba_kernel,
    cbga_build_kernel,
    cbga_kernel,
    cbga_round_kernel,
    kernel_parts,
)
from murdoch.consensus.conflict import NONE, Action, resolve, rule_arrays


def test_each_kernel_names_the_parts_it_was_built_against() -> None:
    digest = hashlib.sha256(Path(kernel_parts.__file__).read_bytes()).hexdigest()
    assert digest == cbba_kernel.PARTS_SHA256, "update PARTS_SHA256 in cbba_kernel.py"
    assert digest == cbga_kernel.PARTS_SHA256, "update PARTS_SHA256 in cbga_kernel.py"
    assert digest == cbga_build_kernel.PARTS_SHA256, "update PARTS_SHA256 in cbga_build_kernel.py"
    assert digest == cbga_round_kernel.PARTS_SHA256, "update PARTS_SHA256 in cbga_round_kernel.py"


def test_the_cbga_run_names_the_bundle_building_it_was_built_against() -> None:
    digest = hashlib.sha256(Path(cbga_build_kernel.__file__).read_bytes()).hexdigest()
    assert digest == cbga_kernel.BUILD_SHA256, "update BUILD_SHA256 in cbga_kernel.py"


def test_the_cbga_run_names_the_round_bookkeeping_it_was_built_against() -> None:
    digest = hashlib.sha256(Path(cbga_round_kernel.__file__).read_bytes()).hexdigest()
    assert digest == cbga_kernel.ROUND_SHA256, "update ROUND_SHA256 in cbga_kernel.py"


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
