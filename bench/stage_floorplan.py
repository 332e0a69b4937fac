"""Cost of a big Stage floorplan: a simulation step with two lasers, against the bundled
Pioneer world (a few wall boxes) and against the same floorplan built one body per box (as
before compound bodies), all measured in the same run, alternating.

The floorplan is drawn here: 800 x 800 pixels over 16 x 16 m with diagonal walls and rings,
which merge badly into boxes (a diagonal wall is one box per pixel row), so it is close to the
worst a real Stage map gives.

    python bench/stage_floorplan.py [--rounds 5] [--steps 20]

Prints per world: boxes, convert and build seconds; then the median step (ms) of each
over the rounds and the ratios big / baseline and one-body-per-box / big.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INCLUDE = ROOT / "worlds" / "stage" / "include"


def _draw(d: Path) -> Path:
    from PIL import Image, ImageDraw

    im = Image.new("L", (800, 800), 255)
    pen = ImageDraw.Draw(im)
    for i in range(8):
        pen.line((100 * i, 0, 100 * i + 300, 700), fill=0, width=5)
        pen.ellipse((50 + 80 * i, 300, 110 + 80 * i, 360), outline=0, width=3)
    im.save(d / "big.png")
    world = d / "big.world"
    world.write_text(
        f'include "{INCLUDE}/pioneer.inc"\ninclude "{INCLUDE}/sick.inc"\n'
        f'include "{INCLUDE}/map.inc"\n'
        'floorplan( name "m" bitmap "big.png" size [16 16 0.8] )\n'
        'pioneer2dx( name "robot1" pose [-7 -7 0 0] sicklaser() )\n'
        'pioneer2dx( name "robot2" pose [7 7 0 0] sicklaser() )\n')
    return world


def _build(path: Path, *, compound: bool = True):
    from player_server.sim import Simulation, bodies
    from worlds.stage import load_stage_world

    t0 = time.perf_counter()
    world = load_stage_world(path)
    t1 = time.perf_counter()
    keep = bodies._MERGE_BOXES_OVER
    if not compound:
        bodies._MERGE_BOXES_OVER = 1 << 30
    try:
        sim = Simulation(world.spec, seed=1)
    finally:
        bodies._MERGE_BOXES_OVER = keep
    t2 = time.perf_counter()
    print(f"{path.name}{'' if compound else ' (one body per box)'}: "
          f"{len(world.spec.arena.obstacles)} boxes, convert {t1 - t0:.2f} s, "
          f"build {t2 - t1:.2f} s")
    sim.step(1)
    return sim


def _steps(sim, n: int) -> float:
    t = time.perf_counter()
    for _ in range(n):
        sim.step(1)
        sim.laser("robot1")
        sim.laser("robot2")
    return (time.perf_counter() - t) / n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = _draw(Path(tmp))
        sims = {"baseline": _build(ROOT / "worlds" / "stage" / "pioneers.world"),
                "big": _build(path), "per_box": _build(path, compound=False)}
        times: dict[str, list[float]] = {k: [] for k in sims}
        for _ in range(args.rounds):
            for name, sim in sims.items():
                times[name].append(_steps(sim, args.steps))
        med = {k: statistics.median(v) * 1000 for k, v in times.items()}
        for sim in sims.values():
            sim.close()
    print(f"step_ms_baseline={med['baseline']:.2f} step_ms_big={med['big']:.2f} "
          f"step_ms_per_box={med['per_box']:.2f} big/baseline={med['big'] / med['baseline']:.1f} "
          f"per_box/big={med['per_box'] / med['big']:.1f}")


if __name__ == "__main__":
    main()
