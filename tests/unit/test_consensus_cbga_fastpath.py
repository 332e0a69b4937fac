"""The compiled synchronous CBGA run equals the agent-based one.

`allocate(..., "cbga")` runs the compiled kernel when it can; the agents of `SyncRunner` are
the reference. Both must give the same assignment, start times, score (bit for bit),
comm_steps, messages, bytes, rounds and the converged / agreed / conflict-free flags: on the
recorded experiment scenarios (fig5, 7, 8 and 10), on the benchmark's scenarios, on the
quitting runs that used to cycle, and on several hundred random scenarios with groups of one
to four agents, equipment (one item per agent, so that same-equipment replacement happens,
or several), prerequisites, windows (closed, open, absent), late availability, bundle
limits, sparse, directed and disconnected graphs, task quitting with different thresholds
and quit limits, team reward on and off, and round limits. Every agent's final bid matrix is
compared too, on some of them.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from murdoch.consensus.cbba_fast import allocate_compiled
from murdoch.consensus.cbga import CbgaAgent, CbgaOptions
from murdoch.consensus.cbga_fast import (
    compiled_cbga_bids,
    compiled_cbga_unsupported,
    load_compiled_cbga,
)
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.scenario import Agent, CommGraph, Scenario, Task
from murdoch.consensus.sweep import jobs_for, run_jobs
from murdoch.consensus.sync_runner import AllocationResult, SyncRunner, allocate
from murdoch.consensus_cli import allocate as allocate_command

pytest.importorskip("numba")

COMPARED = [f.name for f in dataclasses.fields(AllocationResult) if f.name != "extra"]
ROOT = Path(__file__).resolve().parents[2]


def both(s: Scenario, options: CbgaOptions | None = None, max_rounds: int = 1000
         ) -> tuple[AllocationResult, AllocationResult]:
    fast = allocate(s, "cbga", options, max_rounds)
    ref = allocate(s, "cbga", options, max_rounds, compiled=False)
    assert fast.extra["engine"] == "compiled"
    assert ref.extra == {"engine": "agents", "engine_note": "not requested"}
    return fast, ref


def assert_same(fast: AllocationResult, ref: AllocationResult, label: str) -> None:
    for name in COMPARED:
        assert getattr(fast, name) == getattr(ref, name), (label, name)


def random_scenario(rng: np.random.Generator, label: str
                    ) -> tuple[Scenario, CbgaOptions, int]:
    """A random CBGA scenario, options and a round limit (mostly generous)."""
    n = int(rng.integers(1, 9))
    m = int(rng.integers(1, 14))
    dim = int(rng.choice([2, 3]))
    grid = rng.random() < 0.35  # integer geometry and speeds: many exactly equal bids
    windows = rng.random() < 0.8
    with_prereqs = rng.random() < 0.25
    one_item = rng.random() < 0.5  # each agent carries one item: same-equipment replacement
    items = ("cam", "arm", "gps")
    types = ("a", "b")

    def point() -> tuple[float, ...]:
        if grid:
            return tuple(float(v) for v in rng.integers(0, 6, dim))
        return tuple(float(v) for v in rng.uniform(0, 100, dim))

    agents = []
    for i in range(n):
        caps = frozenset(t for t in types if rng.random() < 0.7) if rng.random() < 0.15 else None
        if one_item:
            kit = (frozenset({items[int(rng.integers(0, 3))]}) if rng.random() < 0.8
                   else frozenset())
        else:
            kit = frozenset(e for e in items if rng.random() < 0.5)
        agents.append(Agent(
            id=f"a{i}", pos=point(),
            speed_mps=float(rng.integers(1, 4)) if grid else float(rng.uniform(0.5, 3.0)),
            capabilities=caps, equipment=kit,
            availability_s=0.0 if rng.random() < 0.7 else float(rng.uniform(0, 60))))
    quit_tasks = rng.random() < 0.6
    tasks = []
    for j in range(m):
        start = float(rng.integers(0, 40)) if grid else float(rng.uniform(0, 150))
        end = math.inf if rng.random() < 0.2 else start + (
            float(rng.integers(0, 30)) if grid else float(rng.uniform(0, 60)))
        discount = 0.0 if rng.random() < 0.2 else (
            0.05 if grid else float(rng.uniform(0.001, 0.1)))
        size = int(rng.choice([1, 1, 2, 2, 3, 3, 4]))
        need: frozenset[str] = frozenset()
        if rng.random() < 0.35:
            need = frozenset(e for e in items if rng.random() < 0.5)
            if size == 1 and len(need) > 1:
                need = frozenset(sorted(need)[:1])
        prereqs: tuple[str, ...] = ()
        if with_prereqs and j > 0 and rng.random() < 0.4:
            prereqs = tuple(sorted({f"t{int(q)}" for q in rng.integers(0, j, 2)}))
        quit_after = (float(rng.integers(0, 6))
                      if size > 1 and quit_tasks and rng.random() < 0.8 else None)
        tasks.append(Task(
            id=f"t{j}", pos=point(), type=str(rng.choice(types)),
            reward=100.0 if grid or rng.random() < 0.5 else float(rng.uniform(10, 200)),
            discount=discount, start_s=start, end_s=end,
            duration_s=float(rng.integers(0, 8)) if grid else float(rng.uniform(0, 15)),
            agents_required=size, equipment=need, prerequisites=prereqs,
            quit_after=quit_after,
            team_reward=0.0 if rng.random() < 0.4 else (
                50.0 if grid else float(rng.uniform(0, 100)))))
    ids = [a.id for a in agents]
    kind = rng.choice(["full", "full", "sparse", "directed", "none"])
    if kind == "full":
        graph = CommGraph()
    elif kind == "none":
        graph = CommGraph(False, ())
    else:
        p_edge = float(rng.uniform(0.1, 0.7))
        edges = tuple((ids[a], ids[b]) for a in range(n) for b in range(n)
                      if a != b and (kind == "directed" or a < b) and rng.random() < p_edge)
        graph = CommGraph(kind == "directed", edges)
    depth = None if rng.random() < 0.7 else int(rng.integers(1, 5))
    rounds = 300 if rng.random() < 0.9 else int(rng.integers(1, 8))
    options = CbgaOptions(task_quitting=bool(rng.random() < 0.6),
                          team_reward=bool(rng.random() < 0.5),
                          quit_limit=int(rng.choice([5, 5, 2, 1, 0])))
    s = Scenario(label, tuple(agents), tuple(tasks), windows, depth, graph)
    return s, options, rounds


CBGA_VARIANTS = [(name, v) for name, variants in EXPERIMENTS.items()
                 for v in range(len(variants)) if variants[v].algorithm == "cbga"]


@pytest.mark.parametrize(("experiment", "variant"), CBGA_VARIANTS)
def test_recorded_experiments_identical(experiment: str, variant: int) -> None:
    v = EXPERIMENTS[experiment][variant]
    for agents in (3, 6, 10):
        # (the quitting runs with ten agents are the slow ones on the agents)
        for run in range(1 if agents == 10 and v.options.task_quitting else 2):
            fast, ref = both(v.make(agents, run_seed(0, agents, run)), v.options)
            assert_same(fast, ref, f"{experiment}/{variant}/{agents}/{run}")


def test_bench_scenarios_identical() -> None:
    """The benchmark's CBGA scenarios (10 agents, 20 two-agent tasks, seeds 0..19)."""
    v = EXPERIMENTS["fig5"][1]
    for seed in range(20):
        fast, ref = both(v.make(10, run_seed(0, 10, seed)), v.options)
        assert_same(fast, ref, f"bench {seed}")


@pytest.mark.parametrize("quit_limit", [5, 1])
def test_formerly_cycling_quitting_runs_identical(quit_limit: int) -> None:
    """The fig7 quitting runs that cycled before quits were limited (see
    test_consensus_cbga_quitting.py), with the default limit and with a single quit."""
    cases = [(1, 4, 11), (3, 4, 42), (1, 7, 6), (3, 7, 14), (1, 8, 29), (3, 6, 66),
             (1, 10, 69), (3, 10, 58)]
    for variant, agents, run in cases:
        v = EXPERIMENTS["fig7"][variant]
        options = dataclasses.replace(v.options, quit_limit=quit_limit)
        fast, ref = both(v.make(agents, run_seed(0, agents, run)), options, 300)
        assert_same(fast, ref, f"fig7/{variant}/{agents}/{run}/{quit_limit}")
        assert fast.converged and fast.conflict_free


@pytest.mark.parametrize("block", range(8))
def test_random_scenarios_identical(block: int) -> None:
    """8 x 70 seeded random scenarios."""
    for n in range(70):
        seed = 1000 * block + n
        s, options, rounds = random_scenario(np.random.default_rng(seed), f"r{seed}")
        assert compiled_cbga_unsupported(s, options) is None
        fast, ref = both(s, options, rounds)
        assert_same(fast, ref, f"seed {seed}")


def agent_bids(runner: SyncRunner) -> list[list[list[float]]]:
    out = []
    for a in runner.agents:
        assert isinstance(a, CbgaAgent)
        out.append(a.x)
    return out


@pytest.mark.parametrize(("experiment", "variant"), [("fig7", 2), ("fig7", 3), ("fig8", 2)])
def test_final_bids_identical(experiment: str, variant: int) -> None:
    """Every agent's final winning-bid matrix, bid for bid (team-reward bids are not in the
    result, whose score comes from executing the plan)."""
    v = EXPERIMENTS[experiment][variant]
    for agents in (5, 10):
        s = v.make(agents, run_seed(0, agents, 0))
        runner = SyncRunner(s, "cbga", v.options)
        runner.run()
        assert compiled_cbga_bids(s, v.options) == agent_bids(runner), agents
    for seed in range(40):
        s, options, rounds = random_scenario(np.random.default_rng(9000 + seed), f"b{seed}")
        runner = SyncRunner(s, "cbga", options, rounds)
        runner.run()
        assert compiled_cbga_bids(s, options, rounds) == agent_bids(runner), seed


def test_single_agent_tasks_give_the_compiled_cbba_result() -> None:
    v = EXPERIMENTS["fig5"][0]
    for run in range(3):
        s = v.make(6, run_seed(0, 6, run))
        cbga = allocate(s, "cbga")
        cbba = allocate_compiled(s)
        assert cbga.extra["engine"] == "compiled"
        for name in COMPARED:
            if name != "algorithm":
                assert getattr(cbga, name) == getattr(cbba, name), (run, name)


def test_negative_discount_falls_back_to_agents() -> None:
    agents = (Agent("a0", (0.0, 0.0)), Agent("a1", (5.0, 0.0)))
    tasks = (Task("t0", (1.0, 0.0), discount=-0.01, agents_required=2),
             Task("t1", (2.0, 0.0), discount=0.1))
    s = Scenario("rising", agents, tasks, time_windows=False)
    note = compiled_cbga_unsupported(s)
    assert note is not None and note.startswith("negative discount")
    r = allocate(s, "cbga")
    assert r.extra == {"engine": "agents", "engine_note": note}
    assert r.conflict_free and r.converged
    assert r == dataclasses.replace(allocate(s, "cbga", compiled=False), extra=r.extra)


def test_what_the_kernel_does_not_take_runs_on_the_agents() -> None:
    agents = (Agent("a0", (0.0, 0.0), equipment=frozenset(f"e{q}" for q in range(40))),
              Agent("a1", (5.0, 0.0), equipment=frozenset(f"e{q}" for q in range(40, 63))))
    many = Scenario("kit", agents, (Task("t0", (1.0, 0.0), discount=0.1, agents_required=2,
                                         equipment=frozenset({"e0", "e62"})),))
    empty = Scenario("empty", agents, ())
    for s, start in ((many, "more than 62 kinds"), (empty, "no agents or no tasks")):
        note = compiled_cbga_unsupported(s)
        assert note is not None and note.startswith(start)
        r = allocate(s, "cbga")
        assert r.extra == {"engine": "agents", "engine_note": note}
    assert allocate(many, "cbga").assignment == {"a0": ["t0"], "a1": ["t0"]}


def test_command_line_engines_agree() -> None:
    scenario = ROOT / "worlds" / "scenarios" / "consensus-groups.json"
    runner = CliRunner()
    out = {}
    for engine in ("compiled", "agents"):
        res = runner.invoke(allocate_command, [str(scenario), "--algorithm", "cbga",
                                               "--engine", engine, "--json"])
        assert res.exit_code == 0, res.output
        out[engine] = json.loads(res.stdout)
    assert out["compiled"] == out["agents"]
    assert out["compiled"]["conflict_free"]


def test_sweep_runs_cbga_compiled() -> None:
    jobs = [j for j in jobs_for("fig7", (5,), 2, 3) if j.variant_index in (0, 3)]
    records = run_jobs(jobs, 1)
    for job, rec in zip(jobs, records, strict=True):
        v = EXPERIMENTS["fig7"][job.variant_index]
        ref = allocate(v.make(5, run_seed(3, 5, job.run)), "cbga", v.options, compiled=False)
        assert (rec.score, rec.steps, rec.messages, rec.bytes, rec.converged) == (
            ref.total_score, ref.comm_steps, ref.messages, ref.bytes, ref.converged)


def test_kernel_loads() -> None:
    assert load_compiled_cbga()


# -- the paper's cost and the "total" team reward -----------------------------------------


@pytest.mark.parametrize(("experiment", "variant"), CBGA_VARIANTS)
def test_recorded_experiments_identical_with_the_paper_cost(experiment: str, variant: int
                                                            ) -> None:
    v = EXPERIMENTS[experiment][variant]
    modes = ("bonus", "total") if v.options.team_reward else ("bonus",)
    for agents in (3, 6):
        for mode in modes:
            s = dataclasses.replace(v.make(agents, run_seed(0, agents, 1)), cost="paper")
            options = dataclasses.replace(v.options, team_mode=mode)
            fast, ref = both(s, options)
            assert_same(fast, ref, f"{experiment}/{variant}/{agents}/{mode}")


@pytest.mark.parametrize("block", range(4))
def test_random_scenarios_identical_with_the_paper_cost(block: int) -> None:
    """4 x 50 seeded random scenarios scored with the paper's linear cost (scores that go
    negative included), half of them with the "total" team reward."""
    for n in range(50):
        seed = 50_000 + 1000 * block + n
        rng = np.random.default_rng(seed)
        s, options, rounds = random_scenario(rng, f"p{seed}")
        s = dataclasses.replace(s, cost="paper")
        options = dataclasses.replace(options, team_mode="total" if n % 2 else "bonus")
        assert compiled_cbga_unsupported(s, options) is None
        fast, ref = both(s, options, rounds)
        assert_same(fast, ref, f"seed {seed}")


def test_final_bids_identical_with_the_paper_cost_and_total_team_reward() -> None:
    for seed in range(30):
        s, options, rounds = random_scenario(np.random.default_rng(70_000 + seed), f"q{seed}")
        s = dataclasses.replace(s, cost="paper")
        options = dataclasses.replace(options, team_reward=True, team_mode="total")
        runner = SyncRunner(s, "cbga", options, rounds)
        runner.run()
        assert compiled_cbga_bids(s, options, rounds) == agent_bids(runner), seed
