"""Each allocator against a reference allocator, seed by seed (`murdoch compare`'s second table).

Every allocator of a comparison runs on the same seeds, and a seed fixes the task stream, the
batteries and the faults. So the seed-to-seed spread, which is large (one seed brings twice the
tasks of another), is shared by all allocators, and a difference between two allocators is best
read seed by seed: for each seed, an allocator's figure minus the reference's on the same seed.
The mean of those differences, with a 95 % interval (Student's t over the seeds), says whether
the two differ even when their spreads over seeds overlap.

Pure: rows in (as `compare.run_row` makes them), `Paired` figures, a table, a CSV and a plot out.
"""

from __future__ import annotations

import csv
import math
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REFERENCE = "optimal"
"""The default reference: the exact central assignment."""


@dataclass(frozen=True, slots=True)
class Paired:
    """One allocator's figure against the reference's, over the seeds both have it."""

    allocator: str
    metric: str
    differences: tuple[float, ...]
    """Allocator minus reference, one per shared seed, in seed order."""

    @property
    def n(self) -> int:
        return len(self.differences)

    @property
    def mean(self) -> float | None:
        return statistics.fmean(self.differences) if self.differences else None

    @property
    def half_width(self) -> float | None:
        """Half the 95 % interval of the mean difference (None under two seeds)."""
        if self.n < 2:
            return None
        from scipy.stats import t

        spread = statistics.stdev(self.differences) / math.sqrt(self.n)
        return float(t.ppf(0.975, self.n - 1)) * spread

    @property
    def above(self) -> int:
        """Seeds on which the allocator's figure is above the reference's."""
        return sum(1 for d in self.differences if d > 0)

    @property
    def below(self) -> int:
        return sum(1 for d in self.differences if d < 0)

    @property
    def differs(self) -> bool:
        """The 95 % interval leaves out zero."""
        mean, half = self.mean, self.half_width
        return mean is not None and half is not None and abs(mean) > half


def _value(row: Mapping[str, Any], key: str) -> float | None:
    value = row.get(key)
    if value is None or value == "" or row.get("sim_time_s") in (None, ""):
        return None
    number = float(value)
    return number if math.isfinite(number) else None


def paired(rows: Sequence[Mapping[str, Any]], metrics: Sequence[tuple[str, str]],
           reference: str = REFERENCE) -> list[Paired]:
    """For every allocator but the reference (in the rows' order) and every metric: the
    differences on the seeds where both runs have the figure. Empty without the reference."""
    ref = {int(r["seed"]): r for r in rows if r["allocator"] == reference}
    if not ref:
        return []
    names = list(dict.fromkeys(str(r["allocator"]) for r in rows if r["allocator"] != reference))
    out = []
    for name in names:
        own = sorted((int(r["seed"]), r) for r in rows if r["allocator"] == name)
        for key, _label in metrics:
            diffs = []
            for seed, row in own:
                mine, theirs = _value(row, key), (_value(ref[seed], key) if seed in ref else None)
                if mine is not None and theirs is not None:
                    diffs.append(mine - theirs)
            out.append(Paired(name, key, tuple(diffs)))
    return out


def _cell(p: Paired) -> str:
    mean, half = p.mean, p.half_width
    if mean is None:
        return "-"
    digits = 0 if abs(mean) >= 100 else 1
    text = f"{mean:+.{digits}f}"
    if half is not None:
        text += f" ± {half:.{digits}f}"
    return f"{text}{' *' if p.differs else ''} ({p.above}↑ {p.below}↓)"


def format_paired(pairs: Sequence[Paired], metrics: Sequence[tuple[str, str]],
                  reference: str = REFERENCE) -> str:
    """One line per metric, one column per allocator: mean difference from the reference ±
    half its 95 % interval, `*` where the interval leaves out zero, and on how many seeds the
    allocator was above (↑) and below (↓) the reference."""
    names = list(dict.fromkeys(p.allocator for p in pairs))
    cells = {(p.allocator, p.metric): _cell(p) for p in pairs}
    keys = [key for key, _ in metrics if any(p.metric == key and p.n for p in pairs)]
    labels = dict(metrics)
    head = (f"minus {reference}, same seed", *names)
    rows = [head, *[(labels[k], *(cells.get((n, k), "-") for n in names)) for k in keys]]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join("  ".join([r[0].ljust(widths[0]),
                                *(c.rjust(w) for c, w in zip(r[1:], widths[1:], strict=True))])
                     for r in rows)


def write_paired_csv(pairs: Sequence[Paired], path: Path, reference: str = REFERENCE) -> None:
    """A row per (allocator, metric): the mean difference, the interval, the seed counts and
    the differences themselves."""
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(["allocator", "reference", "metric", "seeds", "mean_difference",
                         "ci95_half_width", "seeds_above", "seeds_below", "differences"])
        for p in pairs:
            writer.writerow([p.allocator, reference, p.metric, p.n,
                             None if p.mean is None else round(p.mean, 4),
                             None if p.half_width is None else round(p.half_width, 4),
                             p.above, p.below, " ".join(f"{d:g}" for d in p.differences)])


def plot_paired(pairs: Sequence[Paired], metrics: Sequence[tuple[str, str]], path: Path,
                title: str, reference: str = REFERENCE) -> Path:
    """One panel per metric that has differences: a bar per allocator (mean difference, with
    its 95 % interval) and a dot per seed; zero, the reference, as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = ("#1c7ed6", "#f08c00", "#2f9e44", "#ae3ec9", "#e03131")
    keys = [(k, label) for k, label in metrics if any(p.metric == k and p.n for p in pairs)]
    names = list(dict.fromkeys(p.allocator for p in pairs))
    columns = min(4, max(1, len(keys)))
    rows = max(1, math.ceil(len(keys) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.6 * columns, 3.3 * rows), dpi=100,
                             squeeze=False)
    for ax in axes.flat[len(keys):]:
        ax.set_visible(False)
    for ax, (key, label) in zip(axes.flat, keys, strict=False):
        for i, name in enumerate(names):
            p = next((q for q in pairs if q.allocator == name and q.metric == key), None)
            if p is None or p.mean is None:
                continue
            colour = colours[i % len(colours)]
            ax.bar(i, p.mean, yerr=p.half_width, color=colour, alpha=0.55, capsize=4)
            ax.scatter([i] * p.n, p.differences, s=12, color=colour, zorder=3)
        ax.axhline(0.0, color="black", linestyle="--", linewidth=0.8, zorder=2)
        ax.set_xticks(range(len(names)), names)
        ax.set_title(f"{label}\nminus {reference}", fontsize="medium")
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def against_reference(rows: Sequence[Mapping[str, Any]], metrics: Sequence[tuple[str, str]],
                      out: Path, title: str, reference: str = REFERENCE) -> str | None:
    """The paired table as text, after writing `comparison-paired.csv` and `.png` into
    `out`; None (and nothing written) when the reference or every other allocator is missing."""
    pairs = paired(rows, metrics, reference)
    if not any(p.n for p in pairs):
        return None
    write_paired_csv(pairs, out / "comparison-paired.csv", reference)
    plot_paired(pairs, metrics, out / "comparison-paired.png", title, reference)
    return format_paired(pairs, metrics, reference)
