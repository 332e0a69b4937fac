"""The CBGA paper's terms: its linear cost, its step count, its dense data format and its
team reward.

- ``cost: "paper"`` scores a task ``reward - ((start - ref) + duration)``: insertion gains
  equal brute-force re-timing, the bounds that prune candidates hold (also where scores are
  negative), pruning changes no allocation, and the exact solver still finds the optimum.
- ``pairwise_steps`` counts the sends that carry changed allocation data; ``bytes_dense``
  the same messages as dense matrices.
- Team mode "total": a group bid is the agent's gain for every member it completes with.

(The agents and both compiled kernels agree under the paper's cost and the "total" team
reward in `test_consensus_fastpath.py` and `test_consensus_cbga_fastpath.py`.)
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from sibling import load_sibling

from murdoch.consensus.allocation_result import dense_message_size
from murdoch.consensus.cbga import CbgaAgent, CbgaOptions
from murdoch.consensus.exact import solve_exact
from murdoch.consensus.experiments import EXPERIMENTS, TaskSpec, make_scenario, run_seed
from murdoch.consensus.gains import PathGains
from murdoch.consensus.messages import dense_encoded_size, encoded_size
from murdoch.consensus.scenario import (
    Agent,
    Scenario,
    ScenarioError,
    Task,
    parse_scenario,
    scenario_to_dict,
)
from murdoch.consensus.scoring import Problem, build_problem, path_starts, task_scores
from murdoch.consensus.small_problems import SHAPES, small_problem
from murdoch.consensus.sync_runner import SyncRunner, allocate
from murdoch.consensus_cli import allocate as allocate_command
from murdoch.consensus_cli import sweep as sweep_command

# -- scoring -----------------------------------------------------------------------------


def test_the_paper_cost_is_reward_less_delay_and_duration() -> None:
    t = Task("t", (10.0, 0.0), reward=100.0, discount=0.5, start_s=20.0, end_s=90.0,
             duration_s=7.0)
    s = Scenario("one", (Agent("a", (0.0, 0.0), speed_mps=0.25),), (t,), cost="paper")
    p = build_problem(s)
    # arrives at 40 s, 20 s after the window opened: 100 - (20 + 7); discount unused
    assert task_scores(p, np.array([0]), np.array([40.0]))[0] == pytest.approx(73.0)
    assert allocate(s, "cbba").total_score == pytest.approx(73.0)
    s2 = dataclasses.replace(s, cost="discount")
    assert allocate(s2, "cbba").total_score == pytest.approx(100 * math.exp(-0.5 * 20))


def test_scenario_files_carry_the_cost() -> None:
    data = {"agents": [{"id": "a", "pos": [0, 0]}], "tasks": [{"id": "t", "pos": [1, 0]}]}
    assert parse_scenario(data).cost == "discount"
    assert "cost" not in scenario_to_dict(parse_scenario(data))  # the default is implied
    paper = parse_scenario({**data, "cost": "paper"}, "x.json")
    assert paper.cost == "paper"
    assert parse_scenario(scenario_to_dict(paper)).cost == "paper"
    with pytest.raises(ScenarioError, match=r"x\.json: cost: expected 'discount' or 'paper'"):
        parse_scenario({**data, "cost": "linear"}, "x.json")


def _problem(seed: int, open_windows: bool) -> Problem:
    """Nine tasks for two agents, scored with the paper's cost; with open windows the
    reference is time 0, so late tasks score below zero."""
    rng = np.random.default_rng(seed)
    specs = [TaskSpec(open_window=open_windows and j % 2 == 0) for j in range(9)]
    s = make_scenario("g", rng, [frozenset()] * 2, specs)
    return build_problem(dataclasses.replace(s, cost="paper"))


def _score(p: Problem, path: list[int], times: list[float]) -> float:
    if not path:
        return 0.0
    return float(task_scores(p, np.asarray(path), np.asarray(times)).sum())


def _brute(p: Problem, path: list[int], times: list[float], c: int,
           not_before: float) -> float:
    base = _score(p, path, times)
    best = -math.inf
    for n in range(len(path) + 1):
        cand = [*path[:n], c, *path[n:]]
        bounds = dict(zip(path, times, strict=True))
        bounds[c] = not_before
        t, ok = path_starts(p, 0, cand, bounds)
        if ok:
            best = max(best, _score(p, cand, t) - base)
    return best


def _grow(p: Problem, rng: np.random.Generator, path: list[int], steps: int) -> list[int]:
    for _ in range(steps):
        options = [(c, n) for c in range(p.n_tasks) if c not in path
                   for n in range(len(path) + 1)
                   if path_starts(p, 0, [*path[:n], c, *path[n:]])[1]]
        if not options:
            break
        c, n = options[int(rng.integers(len(options)))]
        path = [*path[:n], c, *path[n:]]
    return path


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.integers(0, 6), st.booleans(),
       st.sampled_from([0.0, 40.0, 120.0]))
def test_gains_match_brute_force(seed: int, length: int, open_windows: bool,
                                 not_before: float) -> None:
    p = _problem(seed, open_windows)
    path = _grow(p, np.random.default_rng(seed + 1), [], length)
    times, ok = path_starts(p, 0, path)
    assert ok
    gains = PathGains(p, 0, path, times)
    for c in range(p.n_tasks):
        if c in path:
            continue
        got, _ = gains.gain(c, not_before)
        want = _brute(p, path, times, c, not_before)
        assert math.isfinite(got) == math.isfinite(want), (c, got, want)
        if math.isfinite(want):
            assert got == pytest.approx(want, rel=1e-9, abs=1e-9)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.integers(0, 3), st.integers(1, 4), st.booleans())
def test_bounds_hold_on_grown_paths(seed: int, start_len: int, grow: int,
                                    open_windows: bool) -> None:
    """The bound an ancestor path leaves (`upper_bound`) and the direct-travel bound the
    kernels order candidates by (`gain_bound`) are never below a gain on a grown path,
    negative gains included."""
    p = _problem(seed, open_windows)
    rng = np.random.default_rng(seed + 7)
    path = _grow(p, rng, [], start_len)
    times, _ = path_starts(p, 0, path)
    ancestor = PathGains(p, 0, path, times)
    for c in range(p.n_tasks):
        if c not in path:
            ancestor.gain(c)
    bounds = ancestor.bounds()
    path = _grow(p, rng, path, grow)
    times, _ = path_starts(p, 0, path)
    grown = PathGains(p, 0, path, times, dict(bounds))
    for c in range(p.n_tasks):
        if c in path:
            continue
        gain, _ = PathGains(p, 0, path, times).gain(c)
        assert gain <= grown.upper_bound(c), (c, gain, grown.upper_bound(c))
        assert gain <= p.gain_bound[0, c], (c, gain, p.gain_bound[0, c])


def test_negative_scores_keep_a_valid_bound_and_are_not_bid() -> None:
    """A task 300 s away is worth 100 - (300 + 5) < 0: its bound is negative and still at
    least its gain (a relative margin would push a negative bound below it), and nobody
    takes it, on either engine."""
    agents = (Agent("a", (0.0, 0.0), speed_mps=1.0),)
    tasks = (Task("near", (10.0, 0.0), duration_s=5.0),
             Task("far", (300.0, 0.0), duration_s=5.0))
    s = Scenario("far", agents, tasks, time_windows=False, cost="paper")
    p = build_problem(s)
    gain, _ = PathGains(p, 0, [], []).gain(1)
    assert gain == pytest.approx(100.0 - 305.0)
    assert gain <= p.gain_bound[0, 1] < 0
    for compiled in (False, True):
        r = allocate(s, "cbba", compiled=compiled)
        assert r.assignment == {"a": ["near"]}
        assert r.total_score == pytest.approx(85.0)


_without_pruning = load_sibling(__file__, "test_consensus_gains.py")._without_pruning
brute_force = load_sibling(__file__, "test_consensus_exact.py").brute_force


CASES = [("fig5", 0, 6, 3), ("fig5", 1, 7, 4), ("fig5", 2, 5, 1), ("fig7", 2, 8, 2),
         ("fig8", 2, 6, 0), ("fig10", 1, 6, 2), ("fig10", 2, 5, 3)]


@pytest.mark.parametrize(("experiment", "variant", "agents", "run"), CASES)
def test_pruned_bundles_equal_full_evaluation(experiment: str, variant: int, agents: int,
                                              run: int, monkeypatch: pytest.MonkeyPatch
                                              ) -> None:
    v = EXPERIMENTS[experiment][variant]
    scenario = dataclasses.replace(v.make(agents, run_seed(11, agents, run)), cost="paper")
    options = dataclasses.replace(v.options, team_mode="total")
    pruned = allocate(scenario, v.algorithm, options, compiled=False)  # type: ignore[arg-type]
    _without_pruning(monkeypatch)
    full = allocate(scenario, v.algorithm, options, compiled=False)  # type: ignore[arg-type]
    assert pruned == full


# -- the exact solver --------------------------------------------------------------------


@pytest.mark.parametrize("groups", [False, True])
def test_exact_solver_takes_the_paper_cost(groups: bool) -> None:
    for k in range(15):
        rng = np.random.default_rng([5, k, int(groups)])
        n = int(rng.integers(2, 4))
        s = dataclasses.replace(small_problem(rng, n, 4, SHAPES[k % len(SHAPES)],
                                              groups=groups), cost="paper")
        p = build_problem(s)
        best = brute_force(p)
        sol = solve_exact(p)
        assert sol.total_score == pytest.approx(best, abs=1e-6), k
        plain = allocate(s, "cbga" if groups else "cbba")
        assert plain.total_score <= sol.total_score + 1e-6


# -- the paper's step count and data format ----------------------------------------------


def _pair() -> Scenario:
    return Scenario("pair", (Agent("a", (0.0, 0.0)), Agent("b", (10.0, 0.0))),
                    (Task("t", (1.0, 0.0), discount=0.01),))


def test_pairwise_steps_count_sends_with_news() -> None:
    """Round 1: both bid on t and send their bids (2 sends with news); merging, b learns
    that a (nearer) outbids it, which is the last change (comm_steps 1). Round 2: b's
    message differs from its first (it now names a as t's winner), a's repeats (1 send with
    news, after comm_steps, so not counted); nothing changes after."""
    for compiled in (False, True):
        r = allocate(_pair(), "cbba", compiled=compiled)
        assert r.assignment == {"a": ["t"], "b": []}
        assert (r.comm_steps, r.messages, r.pairwise_steps) == (1, 2, 2), compiled
    runner = SyncRunner(_pair(), "cbba")
    runner.run()
    # per round (messages, bytes, sends with news): after round 2 only repeats are sent
    assert [row[2] for row in runner.per_round][:3] == [2, 1, 0]


def test_dense_bytes() -> None:
    # header 17, 20 tasks x 2 places x (u16 + f64 + f64 start), 10 stamps x 8
    assert dense_encoded_size(20, 2, 10, True) == 17 + 20 * 2 * 18 + 80
    assert dense_encoded_size(20, 1, 10, False) == 17 + 20 * 10 + 80
    assert encoded_size(0, 10) == 17 + 80  # the sparse form's header and stamps
    v = EXPERIMENTS["fig5"][1]
    s = v.make(5, run_seed(0, 5, 0))
    for compiled in (False, True):
        r = allocate(s, "cbga", v.options, compiled=compiled)
        size = dense_message_size("cbga", build_problem(s))
        assert size == dense_encoded_size(20, 2, 5, True)
        assert r.bytes_dense == r.messages * size
        assert 0 < r.pairwise_steps <= r.messages


# -- team reward as the paper describes it -----------------------------------------------


def test_total_team_reward_bids_for_the_whole_group() -> None:
    """With one partner already in a two-agent task, the bid is twice the agent's gain
    (the bonus mode adds team_reward * 1 / 1 instead); without one it is the gain."""
    agents = (Agent("a", (0.0, 0.0)), Agent("b", (5.0, 0.0)))
    task = Task("g", (1.0, 0.0), reward=100.0, discount=0.01, agents_required=2,
                team_reward=30.0)
    s = Scenario("team", agents, (task,))
    p = build_problem(s)
    bids = {}
    for mode in ("bonus", "total"):
        for partner in (False, True):
            agent = CbgaAgent(p, 0, CbgaOptions(task_quitting=False, team_mode=mode))
            if partner:
                agent.x[0][1] = 50.0
                agent.t[0][1] = 5.0
            agent.build_bundle(1.0)
            bids[mode, partner] = agent.x[0][0]
    gain = bids["total", False]
    assert gain > 0
    assert bids["bonus", False] == gain
    assert bids["bonus", True] == pytest.approx(
        100.0 * math.exp(-0.01 * 5.0) + 30.0)  # waits for b: starts at 5 s
    assert bids["total", True] == pytest.approx(2 * 100.0 * math.exp(-0.01 * 5.0))


# -- the command line --------------------------------------------------------------------


def test_allocate_takes_the_cost_and_team_mode(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scenario_to_dict(_pair())), encoding="utf-8")
    runner = CliRunner()
    out = {}
    for cost in ("discount", "paper"):
        res = runner.invoke(allocate_command, [str(path), "--cost", cost, "--json",
                                               "--engine", "agents"])
        assert res.exit_code == 0, res.output
        out[cost] = json.loads(res.output)
    assert out["discount"]["total_score"] == pytest.approx(100 * math.exp(-0.01))
    assert out["paper"]["total_score"] == pytest.approx(99.0)  # 100 - (1 s + 0 s)
    assert out["paper"]["pairwise_steps"] == 2
    assert out["paper"]["bytes_dense"] == 2 * dense_encoded_size(1, 1, 2, False)
    res = runner.invoke(allocate_command, [str(path), "--engine", "agents"])
    assert "2 pairwise steps" in res.output
    res = runner.invoke(allocate_command, [str(path), "--cost", "linear"])
    assert res.exit_code != 0 and "--cost" in res.output
    res = runner.invoke(allocate_command, [str(path), "--algorithm", "cbga",
                                           "--team-mode", "total", "--json"])
    assert res.exit_code == 0, res.output


def test_sweep_with_the_paper_cost_reports_the_papers_measures(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "sweep"
    res = CliRunner().invoke(sweep_command, [
        "--experiment", "fig7", "--agents", "4", "--runs", "2", "--jobs", "1",
        "--cost", "paper", "--team-mode", "total", "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((out / "runs.csv").open(encoding="utf-8")))
    assert len(rows) == 8
    assert {r["cost"] for r in rows} == {"paper"}
    assert {r["team_mode"] for r in rows} == {"total"}
    for r in rows:
        assert 0 <= int(r["pairwise_steps"]) <= int(r["messages"])
        assert int(r["bytes_dense"]) > 0 or int(r["messages"]) == 0
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["meta"]["cost"] == "paper"
    assert "pairwise_mean" in summary["rows"][0]
    assert "pairwise steps*" in (out / "results.md").read_text(encoding="utf-8")
