"""Headless demo: ``python -m player_server.sim WORLD.toml --sim-hours 1``.

Every robot wanders on its own range readings and drives to the nearest charger when its
battery runs low; progress lines and a summary (simulated time, wall time, real-time factor,
battery levels) are printed.
"""

from __future__ import annotations

import logging
import time

import click
import numpy as np

from player_server.sim.demo import WanderDriver
from player_server.sim.pacing import Pacer
from player_server.sim.simulation import Simulation
from worlds import WorldError, load_world, world_path


@click.command()
@click.argument("world", default="longterm")
@click.option("--sim-hours", type=float, default=None,
              help="Simulated hours to run (default: the world's quit_time, else 1).")
@click.option("--sim-seconds", type=float, default=None, help="Simulated seconds to run.")
@click.option("--seed", type=int, default=None, help="Override the world's seed.")
@click.option("--fidelity", type=click.Choice(["fast", "render"]), default=None)
@click.option("--speedup", type=float, default=0.0, show_default=True,
              help="Pace against wall time (1 = real time, 0 = as fast as possible).")
@click.option("--sense-all", is_flag=True, help="Also read every device every tick.")
@click.option("--progress", "progress_min", type=float, default=10.0, show_default=True,
              help="Print a progress line every this many simulated minutes (0: never).")
@click.option("-q", "--quiet", is_flag=True)
def main(world: str, sim_hours: float | None, sim_seconds: float | None, seed: int | None,
         fidelity: str | None, speedup: float, sense_all: bool, progress_min: float,
         quiet: bool) -> None:
    """Run WORLD (a .toml path or a bundled world name) headless with wandering robots."""
    logging.basicConfig(level=logging.WARNING if quiet else logging.INFO)
    try:
        spec = load_world(world_path(world))
    except (WorldError, FileNotFoundError) as exc:
        raise click.ClickException(str(exc)) from None
    if sim_seconds is None:
        if sim_hours is not None:
            sim_seconds = sim_hours * 3600.0
        else:
            sim_seconds = spec.sim.quit_time_s or 3600.0
    sim = Simulation(spec, seed=seed, fidelity=fidelity)
    ticks = round(sim_seconds / sim.interval_s)
    driver = WanderDriver(sim, np.random.default_rng(sim.seed), sense_all=sense_all)
    pacer = Pacer(sim.interval_s, speedup, time.perf_counter, time.sleep)
    wall0 = time.perf_counter()

    def progress(done: int) -> None:
        wall = time.perf_counter() - wall0
        batt = " ".join(f"{n}={p:.0f}%" for n, p in _battery(sim).items())
        click.echo(f"sim {sim.time_s / 60:7.1f} min  wall {wall:6.1f} s  "
                   f"rtf {sim.time_s / max(wall, 1e-9):6.1f}  {batt}")

    every = round(progress_min * 60.0 / sim.interval_s) if progress_min > 0 and not quiet else 0
    click.echo(f"world {spec.name}: {len(spec.robots)} robots, {sim.fidelity} fidelity, "
               f"seed {sim.seed}, {ticks} ticks of {sim.interval_s:g} s")
    try:
        for i in range(ticks):
            driver.tick()
            pacer.wait(sim.tick)
            if every and (i + 1) % every == 0:
                progress(i + 1)
    except KeyboardInterrupt:
        click.echo("interrupted")
    wall = time.perf_counter() - wall0
    st = driver.stats
    click.echo("summary")
    click.echo(f"  simulated time  {sim.time_s:.1f} s ({sim.time_s / 3600:.2f} h)")
    click.echo(f"  wall time       {wall:.1f} s")
    click.echo(f"  real-time factor {sim.time_s / max(wall, 1e-9):.1f}")
    for name, p in _battery(sim).items():
        click.echo(f"  {name:10s} battery {p:5.1f}%  min {st.min_percent.get(name, p):5.1f}%  "
                   f"charging {st.charging_s.get(name, 0.0):6.0f} s "
                   f"({st.charge_trips.get(name, 0)} trips)  "
                   f"travelled {st.distance_m.get(name, 0.0):7.1f} m")
    sim.close()


def _battery(sim: Simulation) -> dict[str, float]:
    return {r.name: sim.power(r.name).percent for r in sim.spec.robots
            if r.devices.power is not None}


if __name__ == "__main__":
    main()
