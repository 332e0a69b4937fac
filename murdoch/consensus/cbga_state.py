"""CBGA's per-agent state and the rules on groups (see `murdoch.consensus.cbga`).

`CbgaState` holds an agent's winning-bid matrix X, its group members' times T, the quit
bookkeeping and what follows from the problem; `select_group` and `complete` say which group
a task keeps and whether it is complete.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from murdoch.consensus.cbba import BundleBuilding
from murdoch.consensus.messages import KIND_CBGA
from murdoch.consensus.scoring import _EPS, Problem

Matrix = list[list[float]]


def zeros(rows: int, cols: int) -> Matrix:
    return [[0.0] * cols for _ in range(rows)]


# how team reward enters a group-task bid (on tasks with a team_reward): "bonus" adds
# team_reward * others / (L_j - 1); "total" bids what the whole group earns, the agent's
# own gain for each member, itself and the others already in the group (the paper's "total
# value for a successful task rather than just their individual contribution")
TEAM_MODES = ("bonus", "total")


def team_bound_bonus(ub: float, others: int) -> float:
    """What the "total" team reward can add to a bid whose own gain is at most `ub`, with
    `others` already in the group (a rounding margin included); 0 when ub <= 0."""
    if not ub > 0.0 or others <= 0:
        return 0.0
    return ub * others + 1e-9 * (1.0 + ub * (1 + others))


@dataclass(frozen=True)
class CbgaOptions:
    task_quitting: bool = True
    team_reward: bool = True
    # an agent quits one group task at most this many times, then gives it up for the run
    quit_limit: int = 5
    team_mode: str = "bonus"  # one of TEAM_MODES


class CbgaState(BundleBuilding):
    """One agent's CBGA state: X (M x N), T (M x N), timestamps, bundle, path, quit
    bookkeeping (plain lists: the problems are small)."""

    kind = KIND_CBGA

    def __init__(self, problem: Problem, index: int, options: CbgaOptions | None = None
                 ) -> None:
        self._init_agent(problem, index)
        self.options = options or CbgaOptions()
        self.x = zeros(problem.n_tasks, problem.n_agents)
        # when each believed member can be at each group task on its own (0 = unknown)
        self.t = zeros(problem.n_tasks, problem.n_agents)
        self.assigned_at = [math.nan] * problem.n_tasks
        # task quitting: per task, the other members seen when this agent last quit it (it
        # stays out until the group is larger; -1 = no ban) and how often it quit it
        self.banned = [-1] * problem.n_tasks
        self.quits = [0] * problem.n_tasks
        self.yielding: dict[int, bool] = {}  # a late group task kept one round (see below)
        # group tasks given up to a higher-index partner -> the other members then
        self.yielded: dict[int, frozenset[int]] = {}
        self._partners: dict[int, float] | None = None
        self._candidates: list[tuple[int, float, float, bool, float]] | None = None
        self._refresh_static()

    def _refresh_static(self) -> None:
        p = self.problem
        self.single: list[bool] = [int(r) == 1 for r in p.required]
        self.single_idx = [j for j, one in enumerate(self.single) if one]
        self.group_idx = [j for j, one in enumerate(self.single) if not one]
        self._latest = [w + _EPS for w in p.lists.window_end]
        self._no_equipment = [not e for e in p.task_equipment]

    def state_key(self) -> tuple[tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...],
                                 tuple[int, ...]]:
        """What `comm_steps` watches: bids, group members' times and bundle."""
        return tuple(map(tuple, self.x)), tuple(map(tuple, self.t)), tuple(self.bundle)

    # -- equipment ----------------------------------------------------------------------
    def select_group(self, j: int, bids: dict[int, float]) -> list[int]:
        """The group task j keeps from candidate (agent -> bid) pairs: strongest first (equal
        bids: higher agent index first), each taken while the group has room and can still
        cover the task's equipment with one new item per remaining place. With agents that
        carry one item each this keeps the paper's rule: a newcomer replaces only the
        weakest member with the same equipment, and only with a higher bid."""
        p = self.problem
        need = p.task_equipment[j]
        size = p.lists.required[j]
        order = sorted(bids, key=lambda m: (-bids[m], -m))
        if not need:
            return order[:size]
        chosen: list[int] = []
        covered: set[str] = set()
        for m in order:
            if len(chosen) >= size:
                break
            eq = p.agent_equipment[m]
            if len(need - covered - eq) > size - len(chosen) - 1:
                continue
            chosen.append(m)
            covered |= eq
        return chosen

    def complete(self, j: int) -> bool:
        members = [m for m, v in enumerate(self.x[j]) if v > 0]
        if len(members) < self.problem.lists.required[j]:
            return False
        covered: set[str] = set()
        for m in members:
            covered |= self.problem.agent_equipment[m]
        return self.problem.task_equipment[j] <= covered
