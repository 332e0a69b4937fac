"""CBGA agents with one UDP multicast socket each, on loopback, converging for real."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from murdoch.consensus import CbgaOptions
from murdoch.consensus.async_runner import CONSENSUS_CODEC, ConsensusSwarm, make_nodes
from murdoch.consensus.experiments import TaskSpec, make_scenario
from murdoch.endpoint import EndpointOptions
from murdoch.multicast import MulticastConfig, MulticastTransport


def _free_config() -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port)


@pytest.mark.timeout(60)
def test_cbga_over_loopback_multicast() -> None:
    config = _free_config()
    s = make_scenario("mcast", np.random.default_rng(5), [frozenset()] * 4,
                      [TaskSpec(1 + j % 2) for j in range(8)])
    try:
        transports = [MulticastTransport(a.id, time.monotonic, config,
                                         EndpointOptions(CONSENSUS_CODEC))
                      for a in s.agents]
    except OSError as exc:
        pytest.skip(f"UDP multicast on loopback is not available: {exc}")
    nodes = make_nodes(s, "cbga", CbgaOptions(False, False), transports, time.monotonic,
                       "mcast")
    period_s = 0.02

    def deliver() -> None:
        deadline = time.monotonic() + period_s
        while time.monotonic() < deadline:
            for t in transports:
                t.poll(0.002)

    try:
        out = ConsensusSwarm(s, "cbga", nodes, deliver, lambda: None).run(max_periods=400)
    finally:
        for n in nodes:
            n.close()
        for t in transports:
            t.close()
    r = out.result
    if out.datagrams and not any(t.counters.received() for t in transports):
        pytest.skip("multicast datagrams are not looped back on this machine")
    assert r.converged and r.conflict_free and r.agreed
    assert out.periods < 400
    assert sum(len(v) for v in r.assignment.values()) > 0


@pytest.mark.timeout(120)
def test_cbga_with_refine_over_loopback_multicast() -> None:
    from murdoch.consensus import allocate
    from murdoch.consensus.refine import RefineOptions
    from murdoch.consensus.small_problems import small_problem

    config = _free_config()
    s = small_problem(np.random.default_rng([41, 0, 1]), 3, 7, "uniform-loose", groups=True)
    try:
        transports = [MulticastTransport(a.id, time.monotonic, config,
                                         EndpointOptions(CONSENSUS_CODEC))
                      for a in s.agents]
    except OSError as exc:
        pytest.skip(f"UDP multicast on loopback is not available: {exc}")
    nodes = make_nodes(s, "cbga", CbgaOptions(), transports, time.monotonic, "mrefine",
                       refine=RefineOptions(seed=1))
    period_s = 0.02

    def deliver() -> None:
        deadline = time.monotonic() + period_s
        while time.monotonic() < deadline:
            for t in transports:
                t.poll(0.002)

    try:
        # periods of wall time: on a loaded machine a period delivers less, so allow many
        out = ConsensusSwarm(s, "cbga", nodes, deliver, lambda: None).run(max_periods=3000)
    finally:
        for n in nodes:
            n.close()
        for t in transports:
            t.close()
    r = out.result
    if out.datagrams and not any(t.counters.received() for t in transports):
        pytest.skip("multicast datagrams are not looped back on this machine")
    assert r.converged and r.conflict_free and r.agreed and not r.incomplete
    assert all(n.refiner is not None and n.refiner.done for n in nodes)
    assert r.total_score >= allocate(s, "cbga", CbgaOptions()).total_score - 1e-6
    assert any(t.counters.sent("consensus-refine") for t in transports)
