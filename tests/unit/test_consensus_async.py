"""CBBA and CBGA agents over the in-memory MURDOCH bus, with seeded loss and reordering."""

from __future__ import annotations

import random
from itertools import pairwise

import numpy as np
import pytest

from murdoch.consensus import CbgaOptions, allocate
from murdoch.consensus.async_runner import (
    CONSENSUS_CODEC,
    ConsensusChunk,
    chunk_message,
    run_on_memory_bus,
    session_name,
    split_state,
)
from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.consensus.messages import KIND_CBGA, ConsensusMessage
from murdoch.consensus.scenario import CommGraph, Scenario
from murdoch.wire import MAX_DATAGRAM_BYTES


def _scenario(seed: int, specs: list[TaskSpec], n_agents: int, line: bool = False) -> Scenario:
    s = make_scenario("async", np.random.default_rng(seed), [frozenset()] * n_agents, specs)
    if not line:
        return s
    ids = [a.id for a in s.agents]
    return Scenario(s.name, s.agents, s.tasks,
                    comm_graph=CommGraph(False, tuple(pairwise(ids))))


@pytest.mark.parametrize(("algorithm", "loss", "line"), [
    ("cbba", 0.0, False), ("cbba", 0.3, True), ("cbga", 0.0, False), ("cbga", 0.3, True),
])
def test_converges_conflict_free_with_loss(algorithm: str, loss: float, line: bool) -> None:
    specs = [TaskSpec(1 if algorithm == "cbba" else 1 + j % 2) for j in range(8)]
    s = _scenario(4, specs, 5, line)
    delay = 0.08 if loss else 0.0  # delays up to 1.6 periods reorder the datagrams
    out = run_on_memory_bus(s, algorithm, random.Random(7), loss=loss, max_delay_s=delay,
                            options=CbgaOptions(False, False))
    r = out.result
    assert r.converged and r.conflict_free and r.agreed
    assert r.messages == out.datagrams > 0
    if loss == 0.0 and not line:
        # without loss or delay a full graph reaches the synchronous result
        assert r.assignment == allocate(s, algorithm, CbgaOptions(False, False)).assignment


def test_runs_are_reproducible_with_a_seed() -> None:
    s = _scenario(9, [TaskSpec(2)] * 6, 4)
    a = run_on_memory_bus(s, "cbga", random.Random(3), loss=0.2, max_delay_s=0.1)
    b = run_on_memory_bus(s, "cbga", random.Random(3), loss=0.2, max_delay_s=0.1)
    assert a == b


def test_large_states_are_split_into_datagrams_that_fit() -> None:
    entries = tuple((j, m, 123.45678901234567 + j + m) for j in range(20) for m in range(10))
    msg = ConsensusMessage(KIND_CBGA, 3, 17.25, entries, tuple([5.0] * 9 + [-np.inf]))
    chunks = split_state(msg, "big", 20)
    assert len(chunks) > 1
    assert sum(c.task_count for c in chunks) == 20
    assert [e for c in chunks for e in c.entries] == list(entries)
    for c in chunks:
        frame = CONSENSUS_CODEC.encode_frame("agent-3", 1, frozenset({"consensus.big"}), c)
        assert len(frame) <= MAX_DATAGRAM_BYTES
        back = CONSENSUS_CODEC.message_of(CONSENSUS_CODEC.parse_frame(frame))
        assert isinstance(back, ConsensusChunk) and back == c
    assert chunk_message(chunks[0], KIND_CBGA).stamps[-1] == -np.inf


def test_session_names_are_valid_subjects() -> None:
    assert session_name("Fig 5: CBBA/two") == "fig-5:-cbba/two"
    assert session_name("***") == "session"
