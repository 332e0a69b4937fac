"""The total score of a joint plan, as `scoring.evaluate_plan` computes it, in plain Python.

`evaluate_plan` is the reference (start times per agent, groups, numpy scores); the
improvement phase of `--refine` scores thousands of candidate plans with group tasks and
needs only the total and which tasks complete. Both execute the plan with
`scoring.execute_jointly`; here the scores use `math.exp` where `evaluate_plan` uses
numpy's, so totals agree to rounding (`test_consensus_refine_pairs.py` compares both on
random plans).
"""

from __future__ import annotations

from collections.abc import Sequence

from murdoch.consensus.scoring import Problem, execute_jointly, task_value


def joint_score(p: Problem, paths: Sequence[Sequence[int]]) -> tuple[float, list[bool]]:
    """(total score, completed per task) of executing `paths` jointly."""
    group, completed, start_of = execute_jointly(p, paths)
    lst = p.lists
    total = 0.0
    for j in range(p.n_tasks):
        if completed[j]:
            total += len(group[j]) * task_value(lst, j, start_of[j])
    return total, completed
