"""Import circles in the shipped packages, every import counted (type-checking ones too).

`python tools/import_cycles.py` builds the import graph of the packages with grimp, finds
its strongly connected components (each a set of modules that import one another, directly
or through each other) and prints each one with a cycle through it; it exits non-zero when
there is one. ``--tolerate PKG`` reports the circles lying wholly inside PKG without failing
on them (for a package whose circles are being taken apart). `make lint` runs it and
`tests/unit/test_import_cycles.py` feeds it a small package with a circle.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("player_server", "behaviors", "murdoch", "worlds", "experiments")

Graph = Mapping[str, Iterable[str]]


def import_graph(packages: Sequence[str]) -> dict[str, set[str]]:
    """Module -> the modules of `packages` it imports (any import statement, anywhere)."""
    import grimp

    g = grimp.build_graph(*packages, include_external_packages=False,
                          exclude_type_checking_imports=False, cache_dir=None)
    return {m: set(g.find_modules_directly_imported_by(m)) for m in g.modules}


def circles(graph: Graph) -> list[list[str]]:
    """The strongly connected components with more than one module (or a module importing
    itself), each sorted, sorted by their first module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    m = stack.pop()
                    on_stack.discard(m)
                    comp.append(m)
                    if m == node:
                        break
                if len(comp) > 1 or node in graph.get(node, ()):
                    out.append(sorted(comp))
    return sorted(out)


def cycle_through(graph: Graph, component: Sequence[str]) -> list[str]:
    """One closed path of imports inside `component`, starting at its first module."""
    members = set(component)
    start = component[0]
    # breadth-first from the start's imports back to the start, inside the component
    paths = {m: [start, m] for m in sorted(graph.get(start, ())) if m in members}
    frontier = list(paths)
    while frontier:
        nxt = []
        for m in frontier:
            if m == start:
                return paths[m]
            for n in sorted(graph.get(m, ())):
                if n in members and n not in paths:
                    paths[n] = paths[m] + [n]
                    nxt.append(n)
        frontier = nxt
    return [start, start]


def report(graph: Graph, tolerate: Sequence[str] = ()) -> tuple[list[str], bool]:
    """Lines naming each circle, and whether any of them fails the check."""
    lines: list[str] = []
    failing = False
    for comp in circles(graph):
        tolerated = any(all(m == p or m.startswith(p + ".") for m in comp) for p in tolerate)
        failing = failing or not tolerated
        tag = "tolerated " if tolerated else ""
        lines.append(f"{tag}import circle of {len(comp)} modules: "
                     + " -> ".join(cycle_through(graph, comp)))
    return lines, failing


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packages", nargs="*", default=list(PACKAGES))
    ap.add_argument("--tolerate", action="append", default=[], metavar="PKG",
                    help="report, without failing, the circles wholly inside PKG")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    lines, failing = report(import_graph(args.packages), args.tolerate)
    for line in lines:
        print(line)
    if not lines:
        print(f"no import circles in {', '.join(args.packages)}")
    return 1 if failing else 0


if __name__ == "__main__":
    raise SystemExit(main())
