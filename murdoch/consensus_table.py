"""What `murdoch allocate` prints: the allocation as a table people can read, scenario names,
and whether the compiled kernels still have to be built.

Pure, except `kernel_cache_warm`, which only looks for numba's cache index files.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

# the compiled entry point of each algorithm: its cache index is written last, when the
# whole kernel has been compiled
KERNEL_ENTRY = {"cbba": ("murdoch.consensus.cbba_kernel", "run_cbba"),
                "cbga": ("murdoch.consensus.cbga_kernel", "run_cbga")}
COMPILE_NOTE = ("compiling the {algorithm} kernel once (10-30 s); later runs load it from "
                "the cache in about 1.5 s")


def kernel_cache_dirs(module: str) -> list[Path]:
    """Where numba keeps the on-disk cache of `module`'s compiled functions."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        return []
    override = os.environ.get("NUMBA_CACHE_DIR")
    if override:  # numba then keeps every cache there, and only there
        return [Path(override)]
    return [Path(spec.origin).parent / "__pycache__"]


def kernel_cache_warm(algorithm: str, dirs: Sequence[Path] | None = None) -> bool:
    """True when numba's cache holds the algorithm's compiled entry point (a load, not a
    compile, on first use). A cache left by an older source is still recompiled by numba; this
    check cannot see that and then says warm."""
    entry = KERNEL_ENTRY.get(algorithm)
    if entry is None:
        return True
    module, func = entry
    stem = module.rsplit(".", 1)[1]
    pattern = f"{stem}.{func}-*.nbi"
    for d in kernel_cache_dirs(module) if dirs is None else dirs:
        if d.is_dir() and any(d.rglob(pattern)):
            return True
    return False


def resolve_scenario(text: str, bundled_dirs: Sequence[Path]) -> Path:
    """A scenario file: `text` itself when it is a file, else the bundled scenario of that
    name (``consensus-small`` or ``consensus-small.json``). Raises `LookupError` naming what
    was looked for and what is bundled."""
    path = Path(text)
    if path.is_file():
        return path
    name = path.name if path.suffix == ".json" else f"{path.name}.json"
    if path.parent == Path("."):
        for d in bundled_dirs:
            candidate = d / name
            if candidate.is_file():
                return candidate
    known = bundled_names(bundled_dirs)
    listed = ", ".join(known) if known else "none"
    raise LookupError(f"no scenario file {text!r} and no bundled scenario of that name "
                      f"(bundled: {listed})")


def bundled_names(bundled_dirs: Iterable[Path]) -> list[str]:
    return sorted({p.stem for d in bundled_dirs if d.is_dir() for p in d.glob("*.json")})


def _time(t: float | None) -> str:
    return "-" if t is None else f"{t:.1f}"


def _list(items: Sequence[str]) -> str:
    return ", ".join(items) if items else "none"


def format_allocation(result: Mapping[str, Any], *, title: str = "") -> str:
    """The allocation (`AllocationResult.to_json()`) as a table: each agent's tasks in
    execution order with their start times, then score, unassigned tasks, agreement and the
    communication used."""
    assignment: Mapping[str, Sequence[str]] = result["assignment"]
    starts: Mapping[str, Sequence[float | None]] = result.get("start_times", {})
    rows = [("agent", "tasks in order", "start times (s)")]
    for agent in assignment:
        tasks = list(assignment[agent])
        times = list(starts.get(agent, [None] * len(tasks)))
        rows.append((agent, " ".join(tasks) or "-",
                     " ".join(_time(t) for t in times) or "-"))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = [title] if title else []
    for i, row in enumerate(rows):
        lines.append("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    yes = {True: "yes", False: "no"}
    lines.append("")
    lines.append(f"total score      {result['total_score']:.2f}")
    lines.append(f"unassigned       {_list(result.get('unassigned', []))}")
    if result.get("incomplete"):
        lines.append(f"incomplete       {_list(result['incomplete'])}")
    lines.append(f"conflict-free    {yes[bool(result.get('conflict_free'))]}   "
                 f"agreed {yes[bool(result.get('agreed'))]}   "
                 f"converged {yes[bool(result.get('converged'))]} "
                 f"in {result.get('rounds', '?')} rounds")
    lines.append(f"communication    {result.get('comm_steps', 0)} steps, "
                 f"{result.get('messages', 0)} messages, {result.get('bytes', 0)} bytes")
    if "pairwise_steps" in result:
        lines.append(f"paper's measures {result['pairwise_steps']} pairwise steps (sends "
                     f"with changed data), {result.get('bytes_dense', 0)} bytes as dense "
                     "matrices")
    return "\n".join(lines)
