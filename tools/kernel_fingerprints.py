"""Keep the compiled kernels' `SOURCES_SHA256` current (numba caches by a function's own file).

Each kernel module of `murdoch/consensus` names the sha256 of every kernel file its compiled
code calls into. `python tools/kernel_fingerprints.py` rewrites those entries, parts before the
modules that use them, after a kernel part changed; `--check` only says whether any is stale
(`tests/unit/test_consensus_kernel_parts.py` runs the check).
"""

from __future__ import annotations

import hashlib
import re
import sys
from pathlib import Path

KERNELS = Path(__file__).resolve().parent.parent / "murdoch" / "consensus"
# every kernel module, parts before their users
ORDER = ("kernel_parts.py", "cbba_kernel.py", "cbga_kernel_parts.py", "cbga_build_kernel.py",
         "cbga_merge_kernel.py", "cbga_kernel.py")
_ENTRY = re.compile(r'^    "([a-z_]+\.py)": "([0-9a-f]{64})",$', re.M)


def digest(name: str) -> str:
    return hashlib.sha256((KERNELS / name).read_bytes()).hexdigest()


def stale() -> list[str]:
    """'module: file' for every fingerprint that no longer matches its file."""
    out = []
    for name in ORDER:
        for dep, recorded in _ENTRY.findall((KERNELS / name).read_text()):
            if digest(dep) != recorded:
                out.append(f"{name}: {dep}")
    return out


def update() -> None:
    for name in ORDER:
        path = KERNELS / name
        text = path.read_text()
        new = _ENTRY.sub(lambda m: f'    "{m.group(1)}": "{digest(m.group(1))}",', text)
        if new != text:
            path.write_text(new)


def main(argv: list[str]) -> int:
    if "--check" in argv:
        found = stale()
        for line in found:
            print(f"stale fingerprint in {line}")
        return 1 if found else 0
    update()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
