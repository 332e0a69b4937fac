"""CBGA bundle building skips candidates it can prove useless without changing a result.

A group task whose members all bid more than an upper bound of this agent's bid keeps them,
so its gain is not computed. The bounds can fall short of a bid by a rounding error: here a
newcomer's team-reward bid equals the four members' bids exactly while the bound was one
unit in the last place lower, and the newcomer (the higher index) takes a place. Skipping on
the bare bound changed this allocation; the recorded numbers are those of evaluating every
candidate.
"""

from __future__ import annotations

import pytest

from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.sync_runner import allocate


@pytest.mark.parametrize(("experiment", "variant", "agents", "run", "score", "steps", "nbytes"), [
    ("fig7", 2, 10, 44, 3960.952527, 15, 1899774),
])
def test_exact_ties_with_full_groups_are_still_evaluated(
        experiment: str, variant: int, agents: int, run: int, score: float, steps: int,
        nbytes: int) -> None:
    v = EXPERIMENTS[experiment][variant]
    result = allocate(v.make(agents, run_seed(0, agents, run)), "cbga", v.options)
    assert result.converged
    assert result.total_score == pytest.approx(score, abs=1e-6)
    assert (result.comm_steps, result.bytes) == (steps, nbytes)
