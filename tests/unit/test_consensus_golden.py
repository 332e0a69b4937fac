"""Seeded experiment scenarios give exactly the recorded allocations.

The rows were recorded from the reference implementation (same assignment, score, comm steps
and messages); any change to bid evaluation or conflict resolution that is meant to be a pure
speed-up must keep them. Every row is checked both compiled and on the agents. The
assignment is compared through a short digest of its JSON.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json

import pytest

from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.sync_runner import allocate

# (experiment, variant, agents, run, assignment digest, total score, comm steps, messages)
GOLDEN = [
    ("fig5", 0, 3, 0, "29790228317b", 1506.568387, 11, 66),
    ("fig5", 0, 3, 1, "216d438d1dcb", 1622.001730, 5, 30),
    ("fig5", 0, 3, 2, "7c3a5a289c1c", 1516.746345, 6, 36),
    ("fig5", 0, 6, 0, "2e3a4553852d", 1933.436833, 12, 360),
    ("fig5", 0, 6, 1, "4d1eb7cb3ca8", 1885.119850, 11, 330),
    ("fig5", 0, 6, 2, "d297deb5f49e", 1896.440875, 13, 390),
    ("fig5", 0, 10, 0, "098ff306f7c5", 2000.000000, 13, 1170),
    ("fig5", 0, 10, 1, "d6e475ff2453", 1999.749588, 11, 990),
    ("fig5", 0, 10, 2, "da8cedd9f629", 1967.109566, 12, 1080),
    ("fig5", 1, 3, 0, "cb61599ca8bd", 1060.358348, 4, 24),
    ("fig5", 1, 3, 1, "a9a005cedaf8", 1431.599574, 2, 12),
    ("fig5", 1, 3, 2, "57077681846b", 1013.401662, 2, 12),
    ("fig5", 1, 6, 0, "654221a66c4b", 2534.288723, 9, 270),
    ("fig5", 1, 6, 1, "d65054954c76", 2792.470424, 8, 240),
    ("fig5", 1, 6, 2, "b2502621095f", 2626.283768, 6, 180),
    ("fig5", 2, 3, 0, "9cad5b9b29c6", 1527.560586, 4, 24),
    ("fig5", 2, 3, 1, "5a640df7d564", 1139.831030, 8, 48),
    ("fig5", 2, 3, 2, "9f20f0fc5e29", 1389.202257, 6, 36),
    ("fig5", 2, 6, 0, "3f6bec51935d", 2523.905011, 12, 360),
    ("fig5", 2, 6, 1, "4ae1b90bad46", 2045.740653, 15, 450),
    ("fig5", 2, 6, 2, "270ce92cfa35", 2460.529692, 13, 390),
    ("fig8", 1, 4, 0, "64c7751aa56d", 1579.458651, 7, 84),
    ("fig8", 1, 4, 1, "43a1a68b5e6b", 1545.492021, 7, 84),
    ("fig8", 1, 9, 0, "29415d6ba8fa", 2367.313545, 11, 792),
    ("fig8", 1, 9, 1, "b31d70c92538", 2396.948956, 11, 792),
    ("fig8", 2, 4, 0, "175387937ca2", 1614.792027, 7, 84),
    ("fig8", 2, 4, 1, "2bdfcddcb0fd", 1054.770411, 6, 72),
    ("fig8", 2, 9, 0, "c790e691b73e", 2236.073253, 8, 576),
    ("fig8", 2, 9, 1, "45ebea495c97", 2997.547967, 14, 1008),
    ("fig10", 1, 7, 0, "5999534e7238", 1918.875532, 5, 210),
    ("fig10", 1, 7, 1, "53f0dca73ef0", 1846.212251, 5, 210),
    ("fig10", 2, 7, 0, "5b24f1304ab3", 1736.003200, 7, 294),
    ("fig10", 2, 7, 1, "7a04dbde8cab", 1825.685205, 11, 462),
]


def digest(assignment: dict[str, list[str]]) -> str:
    return hashlib.sha1(json.dumps(assignment, sort_keys=True).encode()).hexdigest()[:12]


# every row runs twice: compiled (what `allocate` picks) and on the agents
CASES = [(*row, compiled) for row in GOLDEN for compiled in (True, False)]


@pytest.mark.parametrize(("experiment", "variant", "agents", "run", "sha", "score", "steps",
                          "messages", "compiled"), CASES)
def test_allocation_matches_recorded(experiment: str, variant: int, agents: int, run: int,
                                     sha: str, score: float, steps: int, messages: int,
                                     compiled: bool) -> None:
    v = EXPERIMENTS[experiment][variant]
    result = allocate(v.make(agents, run_seed(0, agents, run)), v.algorithm,  # type: ignore[arg-type]
                      v.options, compiled=compiled)
    if compiled and importlib.util.find_spec("numba") is not None:
        assert result.extra["engine"] == "compiled"
    else:
        assert result.extra["engine"] == "agents"
    assert result.converged
    assert digest(result.assignment) == sha, result.assignment
    assert result.total_score == pytest.approx(score, abs=1e-6)
    assert (result.comm_steps, result.messages) == (steps, messages)
