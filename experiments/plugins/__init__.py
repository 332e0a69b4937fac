"""The experiments `murdoch run` knows: one module each, registered here by name.

A new experiment is one module implementing `experiments.experiment.Experiment` and one line
in `EXPERIMENTS`.
"""

from __future__ import annotations

from experiments.experiment import Experiment
from experiments.plugins.boxpush import BOXPUSH
from experiments.plugins.longterm import LONGTERM

EXPERIMENTS: dict[str, Experiment] = {
    LONGTERM.name: LONGTERM,
    BOXPUSH.name: BOXPUSH,
}


def experiment(name: str | None) -> Experiment | None:
    """The registered experiment `name` (None: not one of them, e.g. an old run's name)."""
    return EXPERIMENTS.get(name) if name is not None else None
