"""Distance to the optimum: CBBA, CBGA, their --refine variants and sequential greedy.

Part 1: seeded small problems (`small_problems.py`: uniform and clustered tasks, tight and
loose windows, mixed speeds, capabilities; group tasks with equipment for CBGA), solved
exactly (`exact.py`). Prints, per size and algorithm, the mean and worst ratio to the
optimum, how many runs reached it, and whether every plan was conflict-free with every
assigned task completing.

Part 2: the CBGA paper's set-ups at 10 agents (by default fig5: 20 single-agent tasks, 20
two-agent tasks, 10 + 10; `--experiments fig5,fig7,fig8,fig10` for all), plain vs refined
vs centralised sequential greedy (single-agent tasks only): mean score, and the
communication (rounds, messages, bytes; medians) with the ratio refined / plain per run
(median and worst).

    .venv/bin/python bench/optimality.py            # 20 problems per size, 10 large runs
    .venv/bin/python bench/optimality.py --runs 40 --large-runs 20
    .venv/bin/python bench/optimality.py --skip-small --large-runs 3 \
        --experiments fig7,fig8,fig10
    .venv/bin/python bench/optimality.py --skip-small --large-runs 6 \
        --experiments fig8,fig10 --skip-setups fig10:2
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from murdoch.consensus.exact import solve_exact
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.sga import sequential_greedy
from murdoch.consensus.small_problems import SHAPES, small_problem
from murdoch.consensus.sync_runner import AllocationResult, allocate

SIZES = ((2, 5), (3, 6), (3, 7), (4, 8))


def valid(r: AllocationResult) -> bool:
    return r.conflict_free and not r.incomplete


def small(runs: int, seed: int) -> None:
    print("## Ratio to the optimum on small problems "
          f"({runs} seeded problems per size, shapes {', '.join(SHAPES)})\n")
    print("| problems | agents x tasks | algorithm | mean | worst | optimal | valid |")
    print("|---|---|---|---|---|---|---|")
    totals: dict[tuple[str, str], list[float]] = {}
    for groups in (False, True):
        kind = "groups" if groups else "single"
        for n, m in SIZES:
            ratios: dict[str, list[float]] = {}
            ok: dict[str, int] = {}
            for k in range(runs):
                rng = np.random.default_rng([seed, n, m, k, int(groups)])
                s = small_problem(rng, n, m, SHAPES[k % len(SHAPES)], groups=groups)
                opt = solve_exact(s).total_score
                algos = {"cbga": allocate(s, "cbga"),
                         "cbga --refine": allocate(s, "cbga", refine=True)}
                if not groups:
                    algos = {"cbba": allocate(s, "cbba"),
                             "cbba --refine": allocate(s, "cbba", refine=True),
                             "sequential greedy": sequential_greedy(s), **algos}
                for name, r in algos.items():
                    ratio = r.total_score / opt if opt > 0 else 1.0
                    ratios.setdefault(name, []).append(ratio)
                    totals.setdefault((kind, name), []).append(ratio)
                    ok[name] = ok.get(name, 0) + valid(r)
            for name, rs in ratios.items():
                print(f"| {kind} | {n} x {m} | {name} | {100 * statistics.mean(rs):.1f}% | "
                      f"{100 * min(rs):.1f}% | {sum(x > 1 - 1e-9 for x in rs)}/{len(rs)} | "
                      f"{ok[name]}/{len(rs)} |")
    print("\n| problems | algorithm | mean | worst | optimal |")
    print("|---|---|---|---|---|")
    for (kind, name), rs in totals.items():
        print(f"| {kind} (5-8 tasks, 2-4 agents) | {name} | {100 * statistics.mean(rs):.1f}% | "
              f"{100 * min(rs):.1f}% | {sum(x > 1 - 1e-9 for x in rs)}/{len(rs)} |")


def large(runs: int, seed: int, n_agents: int, experiment: str,
          refined_ratios: list[tuple[float, float, float]],
          skip: frozenset[str] = frozenset()) -> None:
    print(f"\n## The paper's {experiment} set-ups at {n_agents} agents ({runs} runs each)\n")
    print("| set-up | algorithm | score | rounds | messages | bytes | rounds ratio (median, "
          "worst) | msgs ratio (median, worst) | bytes ratio (median, worst) | valid | "
          "solve ms |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for vi, variant in enumerate(EXPERIMENTS[experiment]):
        if f"{experiment}:{vi}" in skip:
            continue
        rows: dict[str, list[tuple[float, int, int, int, bool, float]]] = {}
        for run in range(runs):
            s = variant.make(n_agents, run_seed(seed, n_agents, run))
            # plain and refined alternate on the same scenario
            for name, refine in (("plain", False), ("--refine", True)):
                t0 = time.perf_counter()
                r = allocate(s, variant.algorithm, variant.options,  # type: ignore[arg-type]
                             refine=refine)
                dt = time.perf_counter() - t0
                rows.setdefault(name, []).append(
                    (r.total_score, r.comm_steps, r.messages, r.bytes, valid(r), dt))
            if variant.algorithm == "cbba":
                r = sequential_greedy(s)
                rows.setdefault("sequential greedy", []).append(
                    (r.total_score, 0, 0, 0, valid(r), 0.0))
        base = rows["plain"]
        for name, rs in rows.items():
            med = [statistics.median(x[c] for x in rs) for c in range(1, 4)]
            ratios_r = [x[1] / max(1, b[1]) for x, b in zip(rs, base, strict=True)]
            ratios_m = [x[2] / max(1, b[2]) for x, b in zip(rs, base, strict=True)]
            ratios_b = [x[3] / max(1, b[3]) for x, b in zip(rs, base, strict=True)]
            if name == "--refine":
                refined_ratios.extend(zip(ratios_r, ratios_m, ratios_b, strict=True))
            print(f"| {variant.name} | {name} | {statistics.mean(x[0] for x in rs):.1f} | "
                  f"{med[0]:.0f} | {med[1]:.0f} | {med[2]:.0f} | "
                  f"{statistics.median(ratios_r):.2f}, {max(ratios_r):.2f} | "
                  f"{statistics.median(ratios_m):.2f}, {max(ratios_m):.2f} | "
                  f"{statistics.median(ratios_b):.2f}, {max(ratios_b):.2f} | "
                  f"{sum(x[4] for x in rs)}/{len(rs)} | "
                  f"{1000 * statistics.median(x[5] for x in rs):.0f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="small problems per size")
    ap.add_argument("--large-runs", type=int, default=10, help="runs per fig5 set-up")
    ap.add_argument("--agents", type=int, default=10, help="agents in the fig5 set-ups")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--experiments", default="fig5",
                    help="the paper's experiments for part 2, comma-separated "
                         f"({', '.join(EXPERIMENTS)})")
    ap.add_argument("--skip-small", action="store_true", help="part 2 only")
    ap.add_argument("--skip-setups", default="",
                    help="set-ups of part 2 to leave out, as EXPERIMENT:INDEX, comma-separated "
                         "(fig10:2 is the third set-up of fig10)")
    args = ap.parse_args()
    names = [e.strip() for e in args.experiments.split(",") if e.strip()]
    unknown = [e for e in names if e not in EXPERIMENTS]
    if unknown:
        ap.error(f"--experiments: unknown {', '.join(unknown)} "
                 f"(expected some of {', '.join(EXPERIMENTS)})")
    if not args.skip_small:
        small(args.runs, args.seed)
    skip = frozenset(x.strip() for x in args.skip_setups.split(",") if x.strip())
    refined: list[tuple[float, float, float]] = []
    for name in names:
        large(args.large_runs, args.seed, args.agents, name, refined, skip)
    if refined:
        print(f"\n--refine / plain over all {len(refined)} runs of part 2 (rounds, messages, "
              "bytes):")
        for what, f in (("median", statistics.median), ("mean", statistics.mean),
                        ("worst", max)):
            print(f"- {what}: " + ", ".join(f"{f(r[c] for r in refined):.2f}"
                                            for c in range(3)))


if __name__ == "__main__":
    main()
