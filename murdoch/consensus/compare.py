"""Paired comparisons of sweep runs: what a change does run by run, with standard errors.

Every variant of an experiment, and every sweep with the same seed, sees the same geometry
for the same (agent count, run), so two sets of runs are compared pairwise: the mean of the
per-run differences and its standard error (standard deviation of the differences over the
square root of their number), and how many runs went up, down or stayed. Two kinds:

- `against_first`: within one sweep, each variant against its experiment's first variant
  (for example task quitting against plain CBGA);
- `between`: the same variant in two sweeps (for example the paper's cost against the
  discounted one: the scores are on different scales, the communication is comparable).

Rows are dictionaries as `csv.DictReader` reads a sweep's ``runs.csv``; pure functions.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

METRICS = ("score", "steps", "pairwise_steps", "messages", "bytes", "bytes_dense")

Row = Mapping[str, str]
Key = tuple[str, str, int]  # experiment, variant, agents


@dataclass(frozen=True)
class Paired:
    experiment: str
    variant: str
    reference: str  # what the differences are taken against
    n_agents: int
    metric: str
    runs: int
    mean: float  # of the reference
    diff: float  # mean of (this - reference), run by run
    se: float  # its standard error
    up: int
    down: int
    same: int


def _index(rows: Iterable[Row]) -> dict[Key, dict[int, Row]]:
    out: dict[Key, dict[int, Row]] = {}
    for r in rows:
        key = (r["experiment"], r["variant"], int(r["n_agents"]))
        out.setdefault(key, {})[int(r["run"])] = r
    return out


def _pair(key: Key, reference: str, ref_runs: Mapping[int, Row], runs: Mapping[int, Row],
          metric: str) -> Paired | None:
    common = sorted(set(ref_runs) & set(runs))
    if not common:
        return None
    base = [float(ref_runs[k][metric]) for k in common]
    diffs = [float(runs[k][metric]) - b for k, b in zip(common, base, strict=True)]
    n = len(diffs)
    mean = sum(diffs) / n
    var = sum((d - mean) ** 2 for d in diffs) / (n - 1) if n > 1 else 0.0
    return Paired(key[0], key[1], reference, key[2], metric, n, sum(base) / n, mean,
                  math.sqrt(var / n), sum(d > 0 for d in diffs), sum(d < 0 for d in diffs),
                  sum(d == 0 for d in diffs))


def against_first(rows: Iterable[Row], metric: str, order: Mapping[str, Sequence[str]]
                  ) -> list[Paired]:
    """Each variant against the first variant of its experiment (`order`: experiment ->
    variant names in order), at every agent count both have."""
    idx = _index(rows)
    out = []
    for (exp, variant, n), runs in sorted(idx.items(), key=lambda kv: (
            kv[0][0], _rank(order, kv[0][0], kv[0][1]), kv[0][2])):
        names = order.get(exp, ())
        if not names or variant == names[0]:
            continue
        ref = idx.get((exp, names[0], n))
        if ref is None:
            continue
        p = _pair((exp, variant, n), names[0], ref, runs, metric)
        if p is not None:
            out.append(p)
    return out


def between(base: Iterable[Row], other: Iterable[Row], metric: str,
            reference: str = "base") -> list[Paired]:
    """The same (experiment, variant, agents) in two sweeps: other - base, run by run."""
    a, b = _index(base), _index(other)
    out = []
    for key in sorted(set(a) & set(b)):
        p = _pair(key, reference, a[key], b[key], metric)
        if p is not None:
            out.append(p)
    return out


def _rank(order: Mapping[str, Sequence[str]], exp: str, variant: str) -> int:
    names = list(order.get(exp, ()))
    return names.index(variant) if variant in names else len(names)


def markdown(rows: Sequence[Paired], agents: Sequence[int] | None = None) -> str:
    """A table of paired differences (optionally only some agent counts)."""
    lines = ["| experiment | variant | against | agents | metric | runs | reference mean "
             "| paired difference ± s.e. | up / down / same |",
             "|---|---|---|---|---|---|---|---|---|"]
    for p in rows:
        if agents and p.n_agents not in agents:
            continue
        digits = 0 if abs(p.mean) >= 100 else 1
        lines.append(
            f"| {p.experiment} | {p.variant} | {p.reference} | {p.n_agents} | {p.metric} "
            f"| {p.runs} | {p.mean:.{digits}f} | {p.diff:+.{digits}f} ± {p.se:.{digits}f} "
            f"| {p.up} / {p.down} / {p.same} |")
    return "\n".join(lines) + "\n"
