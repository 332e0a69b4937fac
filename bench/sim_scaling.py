"""Simulator cost per robot from 7 to 1,000 robots: runs ``bench/sim_speed.py`` at each robot
count (fast fidelity, every device read every tick), optionally alternating with a baseline
source tree, and writes a Markdown table and a plot.

    .venv/bin/python bench/sim_scaling.py --baseline-src /path/to/old/checkout \\
        --png docs/figures/sim_scaling.png --table docs/figures/sim_scaling.md

Shorter simulated spans at larger counts keep the sweep to minutes (at least 20 ticks each).
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

COUNTS = (7, 50, 100, 300, 1000)
_LINE = re.compile(r"(\w+)=([0-9.]+)")


def measure(n: int, runs: int, template: str, baseline: str) -> dict[str, float]:
    sim_seconds = max(2.0, min(20.0, 600.0 / n))
    cmd = [sys.executable, str(Path(__file__).with_name("sim_speed.py")), "--robots", str(n),
           "--runs", str(runs), "--sim-seconds", f"{sim_seconds:g}"]
    if template:
        cmd += ["--template", template]
    if baseline:
        cmd += ["--baseline-src", baseline]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    values: dict[str, float] = {}
    for line in out.splitlines()[-3:]:
        values.update({k: float(v) for k, v in _LINE.findall(line)})
    print(out.splitlines()[-1] if out else "", flush=True)
    return values


def table(rows: dict[int, dict[str, float]], baseline: bool) -> str:
    head = "| robots | µs/robot-tick (wall) | µs/robot-tick (CPU) | x real time |"
    rule = "|---|---|---|---|"
    if baseline:
        head += " before: µs (CPU) | before: x real time | speed-up (CPU) |"
        rule += "---|---|---|"
    lines = [head, rule]
    for n, v in rows.items():
        line = (f"| {n} | {v['us_per_robot_tick']:.0f} | {v['cpu_us_per_robot_tick']:.0f} | "
                f"{v['sim_rtf_median']:.2f} |")
        if baseline:
            line += (f" {v['baseline_cpu_us_per_robot_tick']:.0f} | "
                     f"{v['baseline_rtf_median']:.2f} | {v['cpu_speedup_median']:.2f} |")
        lines.append(line)
    return "\n".join(lines) + "\n"


def plot(rows: dict[int, dict[str, float]], baseline: bool, png: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = list(rows)
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    ax.plot(n, [rows[k]["cpu_us_per_robot_tick"] for k in n], "o-",
            label="spatial grids (this version)")
    if baseline:
        ax.plot(n, [rows[k]["baseline_cpu_us_per_robot_tick"] for k in n], "s--",
                label="before: every ray against every footprint")
    ax.set_xscale("log")
    ax.set_ylim(bottom=0)
    ax.set_xlabel("robots in the world")
    ax.set_ylabel("CPU µs per robot per tick")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", default=",".join(map(str, COUNTS)))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--template", default="")
    ap.add_argument("--baseline-src", default="")
    ap.add_argument("--png", type=Path, default=None)
    ap.add_argument("--table", type=Path, default=None,
                    help="write the Markdown table here (and the figures next to it, .json)")
    ap.add_argument("--replot", type=Path, default=None,
                    help="draw the plot from a .json written by an earlier sweep")
    args = ap.parse_args()
    if args.replot is not None:
        data = json.loads(args.replot.read_text(encoding="utf-8"))
        rows = {int(k): v for k, v in data["rows"].items()}
        template, baseline = data["template"], data["baseline"]
    else:
        rows = {}
        for n in (int(c) for c in args.counts.split(",")):
            rows[n] = measure(n, args.runs, args.template, args.baseline_src)
        template, baseline = args.template, bool(args.baseline_src)
    md = table(rows, baseline)
    print(md)
    if args.table is not None and args.replot is None:
        args.table.write_text(md, encoding="utf-8")
        args.table.with_suffix(".json").write_text(json.dumps(
            {"template": template, "baseline": baseline, "rows": rows}, indent=1),
            encoding="utf-8")
    if args.png is not None:
        what = f"copies of {template}" if template else "longterm's robots, cycled"
        plot(rows, baseline, args.png,
             f"bench/sim_speed.py, fast fidelity, {what},\nevery device read every tick")


if __name__ == "__main__":
    main()
