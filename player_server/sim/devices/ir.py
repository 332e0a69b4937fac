"""Infrared proximity beams (`worlds.devices.ir`): PyBullet rays from the body's surface.

Both fidelities cast the same rays: the bodies are PyBullet's in either, and a handful of
short beams per robot costs little beside the scanners' ray casts.
"""

from __future__ import annotations

import math
from typing import ClassVar, cast

import pybullet as pb

from player_server.sim.devices.base import StatelessModel
from worlds.devices.ir import IrSpec, surface_distance

_START_M = 1e-3
"""Beams start this far outside the body, so that they never meet it."""


class IrModel(StatelessModel):
    kinds: ClassVar[tuple[str, ...]] = ("ir",)

    def ranges(self, robot: str) -> tuple[float, ...]:
        """Each beam's range from the body's surface (m), right to left; `max_range` where
        it meets nothing."""
        w = self.world
        st = w.device(robot, "ir")

        def compute() -> tuple[float, ...]:
            spec = cast(IrSpec, st.spec.devices.get("ir"))
            body = st.spec.body
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            cx, cy = st.x + c * body.offset_x_m, st.y + s * body.offset_x_m
            starts, ends = [], []
            for bearing in spec.bearings_rad():
                d = surface_distance(bearing, body.length_m / 2, body.width_m / 2)
                ux, uy = math.cos(st.yaw + bearing), math.sin(st.yaw + bearing)
                near, far = d + _START_M, d + spec.max_range_m
                starts.append((cx + ux * near, cy + uy * near, spec.z_m))
                ends.append((cx + ux * far, cy + uy * far, spec.z_m))
            hits = pb.rayTestBatch(starts, ends, physicsClientId=w.physics_client)
            span = spec.max_range_m - _START_M
            return tuple(_START_M + hit[2] * span if hit[0] >= 0 else spec.max_range_m
                         for hit in hits)

        return w.cached(("ir", st.index), compute)  # type: ignore[return-value]
