"""How fast the long-term team runs against its world alone, and swarm100's speed.

    python bench/team_speed.py [--runs 3] [--until 10m] [--sim-seconds 60]
                               [--swarm-until 2m] [--no-swarm]
                               [--baseline-src TREE] [--baseline-python PY]

Per run, in fresh processes:

* the world alone: `bench/sim_speed.py --runs 1` on the long-term world (every robot
  sensing every tick, no robot processes), its ``sim_rtf_median``;
* the team on the same world: `murdoch run longterm --until T --seed 1` (lockstep, no
  replay page), its real-time factor from summary.json; the ratio team / world alone is how
  much of the world's speed the team keeps;
* swarm100: `murdoch run longterm --world swarm100 --until T2 --seed 1`, its real-time
  factor.

With ``--baseline-src`` the same runs of another source tree (its own bench/sim_speed.py,
with ``--baseline-python``, e.g. that tree's own virtualenv) alternate with this tree's,
so that a busy machine loads both alike, and the medians' ratios are printed (swarm100 only
where the baseline tree has worlds/swarm100.toml). Each team run also reports its
events.jsonl sha256: equal across runs of one tree (lockstep determinism).

The last line reads ``world_rtf_median=<w> team_rtf_median=<t> team_world_ratio=<t/w>
swarm100_rtf_median=<s>`` followed, with a baseline, by ``baseline_team_rtf_median=<b>
team_speedup=<t/b>``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
_SIM_RTF = re.compile(r"sim_rtf_median=([0-9.]+)")


@dataclass
class Tree:
    label: str
    src: Path
    python: str
    world: list[float] = field(default_factory=list)
    team: list[float] = field(default_factory=list)
    swarm: list[float] = field(default_factory=list)
    hashes: set[str] = field(default_factory=set)

    def env(self) -> dict[str, str]:
        return dict(os.environ, PYTHONPATH=str(self.src))

    def has_swarm(self) -> bool:
        return (self.src / "worlds" / "swarm100.toml").is_file()


def load_average() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def world_alone(tree: Tree, sim_seconds: float) -> float:
    bench = tree.src / "bench" / "sim_speed.py"
    out = subprocess.run([tree.python, str(bench), "--runs", "1", "--sim-seconds",
                          f"{sim_seconds:g}"], env=tree.env(), cwd=tree.src,
                         capture_output=True, text=True, check=True).stdout
    m = _SIM_RTF.search(out)
    if m is None:
        raise SystemExit(f"{tree.label}: no sim_rtf_median line from {bench}:\n{out[-500:]}")
    return float(m.group(1))


def team_run(tree: Tree, until: str, world: str | None) -> tuple[float, str]:
    """(real-time factor, events sha256) of one lockstep `murdoch run longterm`."""
    with tempfile.TemporaryDirectory(prefix="team-speed-") as tmp:
        cmd = [tree.python, "-c", "from experiments.cli import main; main()", "run",
               "longterm", "--until", until, "--seed", "1", "--no-replay", "--out", tmp]
        if world is not None:
            cmd += ["--world", world]
        proc = subprocess.run(cmd, env=tree.env(), cwd=tree.src, capture_output=True,
                              text=True, check=False)
        runs = list(Path(tmp).iterdir())
        if proc.returncode != 0 or len(runs) != 1:
            raise SystemExit(f"{tree.label}: murdoch run exited with {proc.returncode}: "
                             f"{proc.stderr[-800:]}")
        summary = json.loads((runs[0] / "summary.json").read_text())
        digest = hashlib.sha256((runs[0] / "events.jsonl").read_bytes()).hexdigest()
    return float(summary["real_time_factor"]), digest


def median(xs: list[float]) -> float:
    return statistics.median(xs) if xs else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--until", default="10m", help="the long-term team's simulated time")
    ap.add_argument("--sim-seconds", type=float, default=60.0,
                    help="simulated seconds of each world-alone run")
    ap.add_argument("--swarm-until", default="2m", help="swarm100's simulated time")
    ap.add_argument("--no-swarm", action="store_true", help="leave swarm100 out")
    ap.add_argument("--baseline-src", type=Path, default=None,
                    help="a source tree measured alternately with this one")
    ap.add_argument("--baseline-python", default=sys.executable,
                    help="the interpreter for the baseline tree (e.g. its own venv's)")
    args = ap.parse_args()
    trees = [Tree("new", HERE, sys.executable)]
    if args.baseline_src is not None:
        trees.insert(0, Tree("baseline", args.baseline_src.resolve(), args.baseline_python))
    for run in range(1, args.runs + 1):
        for t in trees:
            load = load_average()
            w = world_alone(t, args.sim_seconds)
            team, digest = team_run(t, args.until, None)
            t.world.append(w)
            t.team.append(team)
            t.hashes.add(digest)
            line = (f"run {run} {t.label}: load={load:.1f} world_rtf={w:.1f} "
                    f"team_rtf={team:.2f} ratio={team / w:.3f} events_sha256={digest[:12]}")
            if not args.no_swarm and t.has_swarm():
                s, _ = team_run(t, args.swarm_until, "swarm100")
                t.swarm.append(s)
                line += f" swarm100_rtf={s:.2f}"
            print(line, flush=True)
    for t in trees:
        same = "the same" if len(t.hashes) == 1 else f"{len(t.hashes)} different"
        print(f"{t.label}: world_rtf_median={median(t.world):.1f} "
              f"team_rtf_median={median(t.team):.2f} "
              f"ratio_median={median([a / b for a, b in zip(t.team, t.world, strict=True)]):.3f} "
              f"swarm100_rtf_median={median(t.swarm):.2f} ({same} events.jsonl)")
    new = trees[-1]
    last = (f"world_rtf_median={median(new.world):.1f} team_rtf_median={median(new.team):.2f} "
            f"team_world_ratio={median(new.team) / median(new.world):.3f} "
            f"swarm100_rtf_median={median(new.swarm):.2f}")
    if len(trees) == 2:
        base = trees[0]
        last += (f" baseline_team_rtf_median={median(base.team):.2f} "
                 f"team_speedup={median(new.team) / median(base.team):.2f}")
        if base.swarm:
            last += f" swarm100_speedup={median(new.swarm) / median(base.swarm):.2f}"
    print(last)


if __name__ == "__main__":
    main()
