"""CBGA's phase 2 on rows: a sender's single-agent rows by CBBA's table and a group row by
the paper's Algorithm 2 (see `murdoch.consensus.cbga`)."""

from __future__ import annotations

from murdoch.consensus.cbga_state import Matrix
from murdoch.consensus.cbga_times import CbgaTimes
from murdoch.consensus.conflict import NONE, resolve_lists


class CbgaRows(CbgaTimes):
    """How a receiver merges a sender's rows of X and T into its own."""

    def _merge_single_rows(self, k: int, rows: list[int], x_k: Matrix,
                           s_k: list[float]) -> bool:
        """CBBA's rules on single-agent rows (a row's one non-zero entry is y_j, z_j)."""
        m_tasks = self.problem.n_tasks
        y_i, y_k = [0.0] * m_tasks, [0.0] * m_tasks
        z_i, z_k = [NONE] * m_tasks, [NONE] * m_tasks
        for j in rows:
            ri, rk = self.x[j], x_k[j]
            y_i[j] = max(ri)
            z_i[j] = ri.index(y_i[j]) if y_i[j] > 0 else NONE
            y_k[j] = max(rk)
            z_k[j] = rk.index(y_k[j]) if y_k[j] > 0 else NONE
        y_new, z_new = list(y_i), list(z_i)
        if not resolve_lists(self.index, k, y_new, z_new, self.s, y_k, z_k, s_k):
            return False
        for j in rows:
            if y_new[j] != y_i[j] or z_new[j] != z_i[j]:
                row = [0.0] * len(self.x[j])
                if z_new[j] != NONE:
                    row[z_new[j]] = y_new[j]
                self.x[j] = row
        return True

    def _merge_group_row(self, j: int, row_k: list[float], known: list[int],
                         starts_k: list[float]) -> bool:
        """Algorithm 2 for one group row. `known` lists the members the sender knows
        better than this agent (the sender itself, and those it heard from more recently);
        this agent's own entry is never taken from a sender."""
        before = self.x[j]
        row = list(before)
        # phase 1: refresh what we believe from a sender who knows better; phase 2: add
        # the sender's other members, then keep the group select_group picks. Both take
        # the sender's entry for every member it knows better (bids are positive, 0 = not
        # in the group), so the candidates are the row with those entries replaced.
        for m in known:
            row[m] = row_k[m]
        if row != before:
            size = self.problem.lists.required[j]
            if not self._no_equipment[j]:
                bids = {m: v for m, v in enumerate(row) if v > 0}
                row = [0.0] * len(row)
                for m in self.select_group(j, bids):
                    row[m] = bids[m]
            elif size < len(row) - row.count(0.0):
                # select_group without equipment: the `size` strongest stay
                ranked = sorted([m for m, v in enumerate(row) if v > 0],
                                key=lambda m: (-row[m], -m))
                for m in ranked[size:]:
                    row[m] = 0.0
            # (otherwise select_group keeps every candidate: the row stands)
        # planned times follow whoever knows the member better; non-members have none
        starts_before = self.t[j]
        starts = [a if v > 0 else 0.0 for v, a in zip(row, starts_before, strict=True)]
        i = self.index
        starts[i] = starts_before[i]
        for m in known:
            v = row[m]
            if v > 0 and row_k[m] == v:
                starts[m] = starts_k[m]
        changed = row != before or starts != starts_before
        if changed:
            self.x[j] = row
            self.t[j] = starts
        return changed

    # -- releases -----------------------------------------------------------------------
