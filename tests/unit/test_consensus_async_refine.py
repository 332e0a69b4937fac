"""The --refine phase on asynchronous agents over the in-memory bus (seeded loss and
reordering), and its message handling."""

from __future__ import annotations

import math
import random
from itertools import pairwise

import numpy as np
import pytest

from murdoch.consensus import CbgaOptions, allocate
from murdoch.consensus.async_refine import (
    RefineChunk,
    decode_entries,
    encode_entries,
    receive_chunk,
    refine_chunks,
)
from murdoch.consensus.async_runner import CONSENSUS_CODEC, run_on_memory_bus
from murdoch.consensus.refine import (
    PlanScorer,
    Proposal,
    RefineOptions,
    make_refine_agent,
    seeded_rank,
)
from murdoch.consensus.scenario import CommGraph, Scenario
from murdoch.consensus.scoring import build_problem
from murdoch.consensus.small_problems import SHAPES, small_problem
from murdoch.wire import MAX_DATAGRAM_BYTES


def _line(s: Scenario) -> Scenario:
    ids = [a.id for a in s.agents]
    return Scenario(s.name, s.agents, s.tasks, s.time_windows, s.max_depth,
                    CommGraph(False, tuple(pairwise(ids))))


@pytest.mark.parametrize(("groups", "loss", "line"), [
    (False, 0.3, False), (False, 0.3, True), (True, 0.3, False), (True, 0.2, True),
])
def test_refine_over_the_bus_with_loss(groups: bool, loss: float, line: bool) -> None:
    algorithm = "cbga" if groups else "cbba"
    improved = 0
    for k in range(4):
        rng = np.random.default_rng([41, k, int(groups)])
        s = small_problem(rng, 3, 7, SHAPES[k % len(SHAPES)], groups=groups)
        if line:
            s = _line(s)
        plain = run_on_memory_bus(s, algorithm, random.Random(k), loss=loss,
                                  max_delay_s=0.08)
        out = run_on_memory_bus(s, algorithm, random.Random(k), loss=loss, max_delay_s=0.08,
                                refine=RefineOptions(seed=k))
        r = out.result
        assert r.converged and r.conflict_free and r.agreed, k
        assert not r.incomplete, k
        # the phase starts from the plain run's settled plan and never lowers its score
        assert r.total_score >= plain.result.total_score - 1e-9, k
        assert out.datagrams > plain.datagrams
        improved += r.total_score > plain.result.total_score + 1e-6
    assert improved >= 1


def test_without_loss_the_bus_reaches_the_synchronous_refined_plan() -> None:
    for k in range(3):
        rng = np.random.default_rng([42, k])
        s = small_problem(rng, 3, 6, SHAPES[k % len(SHAPES)], groups=True)
        opts = RefineOptions(seed=k, budget=None, opening=False)  # the bus sends paths
        out = run_on_memory_bus(s, "cbga", random.Random(k), refine=opts,
                                options=CbgaOptions())
        sync = allocate(s, "cbga", CbgaOptions(), refine=opts)
        assert out.result.assignment == sync.assignment, k
        assert out.result.total_score == pytest.approx(sync.total_score)


def _agent():
    s = small_problem(np.random.default_rng(1), 3, 5, "uniform-loose")
    p = build_problem(s)
    return make_refine_agent(PlanScorer(p), 0, seeded_rank(3, 0), (0, 1), RefineOptions())


def test_entries_round_trip_and_chunks_fit_a_datagram() -> None:
    entries = {0: (1, 2), 1: Proposal(1, 12.5, ((0, (3,)), (1, (1, 4)))), 2: None}
    back = decode_entries(encode_entries(entries), 3, 5)
    assert back == entries
    # a large step: 40 agents' proposals, each moving tasks of two agents
    a = _agent()
    a.entries = {k: Proposal(k, 1.0 + k, ((k, tuple(range(6))), (k + 1, tuple(range(6)))))
                 for k in range(40)}
    a.previous = (0, {k: tuple(range(8)) for k in range(40)})
    chunks = refine_chunks(a, "session", 0)
    assert len(chunks) > 2
    for chunk in chunks:
        frame = CONSENSUS_CODEC.encode_frame("a0", 1, frozenset({"consensus.session"}), chunk)
        assert len(frame) <= MAX_DATAGRAM_BYTES


@pytest.mark.parametrize("entries", [
    ((7, 0, 0.0, (1,)),),  # unknown agent
    ((1, 0, 0.0, (9,)),),  # unknown task
    ((1, 0, 0.0, (1, 1)),),  # a task twice on one path
    ((1, 1, math.nan, (0, 1, 2)),),  # a gain that is not a number
    ((1, 1, 3.0, (0, 5, 2)),),  # a path shorter than it says
    ((1, 1, 3.0, ()),),  # a proposal changing nothing
    ((1, 4, 0.0, ()),),  # an unknown kind
])
def test_malformed_chunks_are_refused(entries: tuple) -> None:
    a = _agent()
    assert decode_entries(entries, 3, 5) is None
    before = dict(a.entries)
    assert not receive_chunk(a, RefineChunk("s", 1, 0, entries, -1, ()))
    assert a.entries == before
