"""Figures in the style of the CBGA paper (matplotlib, Agg backend, PNG files)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from murdoch.consensus.sweep import Summary

TITLES = {
    "fig5": "Single-agent (CBBA) vs two-agent (CBGA) vs mixed tasks",
    "fig7": "Four-agent tasks: task quitting and team reward",
    "fig8": "Heterogeneous agents and equipment",
    "fig10": "Prerequisites",
}


def score_and_steps(rows: Sequence[Summary], experiment: str, path: Path) -> Path:
    """Score (lines, left axis) and communication steps (x markers, right axis) per agent
    count, one colour per variant, error bars one standard deviation."""
    mine = [r for r in rows if r.experiment == experiment]
    variants = list(dict.fromkeys(r.variant for r in mine))
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    ax2 = ax.twinx()
    for n, v in enumerate(variants):
        rs = sorted((r for r in mine if r.variant == v), key=lambda r: r.n_agents)
        xs = [r.n_agents for r in rs]
        colour = f"C{n}"
        ax.errorbar(xs, [r.score_mean for r in rs], yerr=[r.score_std for r in rs],
                    color=colour, marker="o", ms=3, capsize=2, label=f"{v} score")
        ax2.errorbar(xs, [r.steps_mean for r in rs], yerr=[r.steps_std for r in rs],
                     color=colour, marker="x", ls="--", capsize=2, alpha=0.7,
                     label=f"{v} steps")
    ax.set_xlabel("agents")
    ax.set_ylabel("total score")
    ax.set_ylim(bottom=0)
    ax2.set_ylim(bottom=0)
    ax2.set_ylabel("communication steps (x, converged runs)")
    ax.set_title(TITLES.get(experiment, experiment), fontsize=10)
    ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def score_bars(rows: Sequence[Summary], experiment: str, path: Path) -> Path:
    """Mean score with one-standard-deviation bars per variant at the largest agent count."""
    mine = [r for r in rows if r.experiment == experiment]
    top = max(r.n_agents for r in mine)
    rs = [r for r in mine if r.n_agents == top]
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    ax.bar(range(len(rs)), [r.score_mean for r in rs], yerr=[r.score_std for r in rs],
           color=[f"C{n}" for n in range(len(rs))], capsize=4)
    ax.set_xticks(range(len(rs)), [r.variant for r in rs], fontsize=8)
    ax.set_ylabel("total score")
    ax.set_title(f"{TITLES.get(experiment, experiment)} ({top} agents)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_experiment(rows: Sequence[Summary], experiment: str, out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    agent_counts = {r.n_agents for r in rows if r.experiment == experiment}
    if not agent_counts:
        return paths
    if experiment == "fig7" or len(agent_counts) == 1:
        paths.append(score_bars(rows, experiment, out_dir / f"{experiment}-score.png"))
    if len(agent_counts) > 1:
        paths.append(score_and_steps(rows, experiment, out_dir / f"{experiment}.png"))
    return paths
