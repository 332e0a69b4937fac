"""Bumper panels: pressed where a body touches the robot's front or back end."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import pybullet as pb

if TYPE_CHECKING:
    from player_server.sim.simulation import Simulation


class BumperModel:
    kinds: ClassVar[tuple[str, ...]] = ("bumper",)
    ticking: ClassVar[bool] = False

    def __init__(self, world: Simulation) -> None:
        self.world = world

    def build(self) -> None:
        pass

    def advance(self, dt: float) -> None:
        pass

    def bumpers(self, robot: str) -> tuple[bool, ...]:
        w = self.world
        st = w._device(robot, "bumper")

        def compute() -> tuple[bool, ...]:
            spec = st.spec.devices.bumper
            assert spec is not None
            body = st.spec.body
            contacts = pb.getContactPoints(bodyA=st.body, physicsClientId=w._client)
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            # Contact manifolds report the corners of a touching patch, so each touching body
            # presses every panel whose lateral extent overlaps its patch on that end.
            spans: dict[tuple[int, bool], list[float]] = {}
            reach = 0.6 * body.length_m / 2
            for cp in contacts:
                other = cp[2]
                if other == w._ids.floor or other == st.body:
                    continue
                wx, wy = cp[5][0] - st.x, cp[5][1] - st.y
                lx, ly = c * wx + s * wy - body.offset_x_m, -s * wx + c * wy
                if abs(lx) < reach:
                    continue  # a side contact: no panels there
                span = spans.setdefault((other, lx > 0), [ly, ly])
                span[0], span[1] = min(span[0], ly), max(span[1], ly)
            pressed = [False] * len(spec.segments)
            for (_, front), (lo, hi) in spans.items():
                for i, seg in enumerate(spec.segments):
                    if (seg.x > body.offset_x_m) != front:
                        continue
                    half = seg.length_m / 2 * abs(math.cos(seg.yaw))
                    if seg.y - half <= hi + 0.01 and seg.y + half >= lo - 0.01:
                        pressed[i] = True
            return tuple(pressed)

        return w._cached(("bumpers", st.index), compute)  # type: ignore[return-value]
