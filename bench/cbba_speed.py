"""Solve time of CBBA and CBGA: 10 agents x 20 tasks with time windows, full graph.

The scenarios are the CBGA-paper set-ups of `murdoch.consensus.experiments` (fig5): 20
single-agent tasks for CBBA and 20 two-agent tasks for CBGA, seeds 0..19, no bundle limit.
A solve is a whole synchronous run to convergence (bundle building, consensus rounds and the
final plan evaluation). Both run compiled (`murdoch.consensus.cbba_fast`, `cbga_fast`); the
one-off load or compile time of each kernel is printed first and not counted. Prints one line
per algorithm, then exactly `cbba_solve_ms_median=<x> cbga_solve_ms_median=<y>`.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from murdoch.consensus.cbba_fast import load_compiled_cbba
from murdoch.consensus.cbga_fast import load_compiled_cbga
from murdoch.consensus.experiments import EXPERIMENTS, run_seed
from murdoch.consensus.sync_runner import allocate


def measure(variant_index: int, n_agents: int, seeds: int, repeats: int,
            compiled: bool = True) -> list[float]:
    variant = EXPERIMENTS["fig5"][variant_index]
    times_ms = []
    for seed in range(seeds):
        scenario = variant.make(n_agents, run_seed(0, n_agents, seed))
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            allocate(scenario, variant.algorithm, variant.options,  # type: ignore[arg-type]
                     compiled=compiled)
            best = min(best, time.perf_counter() - t0)
        times_ms.append(1000 * best)
    return times_ms


def machine_load_us() -> float:
    """Microseconds for one small numpy operation: a gauge of how busy the machine is
    (about 0.5-1 us when idle); solve times scale roughly with it."""
    a, b = np.zeros(20), np.ones(20)
    t0 = time.perf_counter()
    for _ in range(20000):
        np.maximum(a, b)
    return (time.perf_counter() - t0) / 20000 * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--agents", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=1,
                        help="solve each scenario this many times and keep the fastest")
    parser.add_argument("--engine", choices=("compiled", "agents"), default="compiled",
                        help="engine of both algorithms (agents: the reference, for "
                             "comparison)")
    args = parser.parse_args()
    print(f"numpy_op_us={machine_load_us():.2f} (before)")
    # numba import + loading the kernel (compiling it when there is no on-disk cache yet)
    t0 = time.perf_counter()
    loaded = load_compiled_cbba()
    print(f"cbba_kernel_load_s={time.perf_counter() - t0:.2f} (compiled CBBA: {loaded})")
    t0 = time.perf_counter()
    loaded = load_compiled_cbga()
    print(f"cbga_kernel_load_s={time.perf_counter() - t0:.2f} (compiled CBGA: {loaded})")
    medians = {}
    for name, index in (("cbba", 0), ("cbga", 1)):
        ms = measure(index, args.agents, args.seeds, args.repeats,
                     compiled=args.engine == "compiled")
        medians[name] = statistics.median(ms)
        print(f"{name}: median {medians[name]:.1f} ms, min {min(ms):.1f}, max {max(ms):.1f} "
              f"over {len(ms)} scenarios")
    print(f"numpy_op_us={machine_load_us():.2f} (after)")
    print(f"cbba_solve_ms_median={medians['cbba']:.1f} cbga_solve_ms_median={medians['cbga']:.1f}")


if __name__ == "__main__":
    main()
