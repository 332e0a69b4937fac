"""This tick's footprints: rectangles, the polygon obstacles' pieces, circles; a held object
leaves the circles (and every array keeps one entry per footprint)."""

from __future__ import annotations

import dataclasses

from player_server.sim import Simulation
from worlds import ObstacleSpec, Pose, load_world, world_path


def test_footprints_with_a_polygon_obstacle_and_a_held_object() -> None:
    spec = load_world(world_path("longterm"))
    ell = ObstacleSpec.polygon("ell", Pose(0.0, -4.0, 0.0),
                               ((0, 0), (2, 0), (2, 0.5), (0.5, 0.5), (0.5, 2), (0, 2)), 0.4, 0)
    arena = dataclasses.replace(spec.arena, obstacles=(*spec.arena.obstacles, ell))
    with Simulation(dataclasses.replace(spec, arena=arena), seed=1) as sim:
        fp = sim.tick_arrays.footprints()
        n_rect = fp.n_rect
        assert fp.n_poly == 2  # the L's two convex pieces, right after the rectangles
        assert fp.top[n_rect:n_rect + 2].tolist() == [0.4, 0.4]
        sim.held.add(spec.objects[0].name)
        sim.update_visibility()
        sim.step()
        held = sim.tick_arrays.footprints()
        assert held.count == fp.count - 1
        assert held.radius.size == held.top.size == held.centre.size == held.count
        assert held.n_poly == 2 and held.n_rect == n_rect
