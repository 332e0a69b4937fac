"""What a caller of `run_experiment` may add to a run beyond the `murdoch run` options.

`murdoch soak` (`experiments.soak`) uses it: a fault schedule of its own (freezes, chargers,
bursts, switch-offs for good), entries for config.json, a seeded source of burst tasks, the
memory sampling period, a way to learn the run directory as soon as it exists, and the
loss layer of the MURDOCH bus (real-time runs only).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from experiments.run_loop import Fault


@dataclass(frozen=True)
class RunExtras:
    faults: tuple[Fault, ...] = ()
    config: dict[str, Any] = field(default_factory=dict)
    burst_seed: int | None = None
    """Seed of the task source the `burst` faults draw from (None: no bursts)."""
    memory_every_s: float = 30.0
    """Wall seconds between memory samples of every process (processes.jsonl)."""
    on_run_dir: Callable[[Path], None] | None = None
    bus_loss: str | None = None
    """`LOSS,DELAY_S,SEED` for every receiver of the bus (real time only; see
    `murdoch.lossy.LossSpec`)."""
