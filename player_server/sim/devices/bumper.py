"""Bumper panels: pressed where a body touches the robot's front or back end."""

from __future__ import annotations

import math
from typing import ClassVar

import pybullet as pb

from player_server.sim.devices.base import StatelessModel
from player_server.sim.grid_index import FEW


class BumperModel(StatelessModel):
    kinds: ClassVar[tuple[str, ...]] = ("bumper",)
    order: ClassVar[int] = 50

    def bumpers(self, robot: str) -> tuple[bool, ...]:
        w = self.world
        st = w.device(robot, "bumper")

        def compute() -> tuple[bool, ...]:
            spec = st.spec.devices.bumper
            assert spec is not None
            body = st.spec.body
            if len(w.robots) < FEW:  # a few robots: ask for this body's contacts only
                contacts = [(cp[2], (cp[5][0], cp[5][1])) for cp in pb.getContactPoints(
                    bodyA=st.body, physicsClientId=w.physics_client)]
            else:
                contacts = self._touching().get(st.body, [])
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            # Contact manifolds report the corners of a touching patch, so each touching body
            # presses every panel whose lateral extent overlaps its patch on that end.
            spans: dict[tuple[int, bool], list[float]] = {}
            reach = 0.6 * body.length_m / 2
            for other, (px, py) in contacts:
                if other == w.ids.floor or other == st.body:
                    continue
                wx, wy = px - st.x, py - st.y
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

        return w.cached(("bumpers", st.index), compute)  # type: ignore[return-value]

    def _touching(self) -> dict[int, list[tuple[int, tuple[float, float]]]]:
        """This tick's contact points by body: (the other body, the point on this body's
        surface), read from PyBullet in one call for every robot (with many robots: a call
        per robot would scan every contact of the world each time)."""
        w = self.world

        def compute() -> dict[int, list[tuple[int, tuple[float, float]]]]:
            by_body: dict[int, list[tuple[int, tuple[float, float]]]] = {}
            for cp in pb.getContactPoints(physicsClientId=w.physics_client):
                a, b = cp[1], cp[2]
                by_body.setdefault(a, []).append((b, (cp[5][0], cp[5][1])))
                if b != a:
                    by_body.setdefault(b, []).append((a, (cp[6][0], cp[6][1])))
            return by_body

        return w.cached("contacts", compute)  # type: ignore[return-value]
