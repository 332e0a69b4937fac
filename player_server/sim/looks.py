"""How bodies look to the sensors: each one's colour and fiducial id.

The world file gives them; the simulation interface may change them while the world runs
(Stage's `color` and `fiducial_return` properties). A `Looks` holds what has been changed
over the world's spec and counts the changes (`version`), so that a model that derived
something from the colours (a blobfinder's plan, say) can tell when to derive it again.
Colours belong to the blob targets (robots, boxes, objects, markers, chargers); fiducial ids
to robots and objects, the things fiducial detectors report.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pybullet as pb

from player_server.sim.bodies import BodyIds
from worlds import WorldSpec, colour_rgb01

MAX_COLOUR = 0xFFFFFF


class Looks:
    """The colours and fiducial ids in force (the world's, until one is set)."""

    def __init__(self, spec: WorldSpec, ids: BodyIds, physics_client: int) -> None:
        self.world = spec
        self._ids = ids  # the bodies to paint (what a rendering camera sees)
        self._cid = physics_client
        self.version = 0
        self._colour: dict[str, int] = {}
        self._fiducial: dict[str, int] = {}
        coloured: tuple[Any, ...] = (*spec.robots, *spec.boxes, *spec.objects,
                                     *spec.markers, *spec.chargers)
        tagged: tuple[Any, ...] = (*spec.robots, *spec.objects)
        self._coloured: dict[str, int] = {t.name: t.colour for t in coloured}
        self._tagged: dict[str, int] = {t.name: t.fiducial_id for t in tagged}

    def colour(self, name: str) -> int:
        """0xRRGGBB of a blob target (KeyError for other names)."""
        got = self._colour.get(name)
        return self._coloured[name] if got is None else got

    def fiducial_id(self, name: str) -> int:
        """The id a fiducial detector reports for a robot or object (0: none)."""
        got = self._fiducial.get(name)
        return self._tagged[name] if got is None else got

    def set_colour(self, name: str, colour: int) -> None:
        if name not in self._coloured:
            raise KeyError(f"{name!r} is not a robot, box, object, marker or charger: "
                           "no colour the sensors see")
        if not 0 <= colour <= MAX_COLOUR:
            raise ValueError(f"colour {colour:#x} is not 0xRRGGBB")
        self._colour[name] = colour
        self.version += 1

    def set_fiducial_id(self, name: str, fiducial_id: int) -> None:
        if name not in self._tagged:
            raise KeyError(f"{name!r} is not a robot or object: fiducial detectors do not "
                           "report it")
        if fiducial_id < 0:
            raise ValueError(f"fiducial id {fiducial_id} is negative")
        self._fiducial[name] = fiducial_id
        self.version += 1

    def change(self, name: str, colour: int | None, fiducial_id: int | None) -> bool:
        """Set what is given (KeyError, ValueError: nothing changed); True when a colour
        changed (the arrays made from the colours are then out of date)."""
        if colour is not None:
            self.set_colour(name, colour)
            paint(self._ids, name, colour, self._cid)
        if fiducial_id is not None:
            self.set_fiducial_id(name, fiducial_id)
        return colour is not None

    def applied(self) -> WorldSpec:
        """The world's spec with the colours and ids in force (for arrays derived from it)."""
        if not (self._colour or self._fiducial):
            return self.world

        def each(items: tuple[Any, ...], ids: bool) -> tuple[Any, ...]:
            out = []
            for t in items:
                new = {}
                if t.name in self._colour:
                    new["colour"] = self._colour[t.name]
                if ids and t.name in self._fiducial:
                    new["fiducial_id"] = self._fiducial[t.name]
                out.append(replace(t, **new) if new else t)
            return tuple(out)

        s = self.world
        return replace(s, robots=each(s.robots, True), boxes=each(s.boxes, False),
                       objects=each(s.objects, True), markers=each(s.markers, False),
                       chargers=each(s.chargers, False))


def paint(ids: BodyIds, name: str, colour: int, cid: int) -> None:
    """Give a blob target's PyBullet body a new colour (what a rendering camera sees)."""
    for bodies in (ids.robots, ids.boxes, ids.objects, ids.markers, ids.chargers):
        if name in bodies:
            pb.changeVisualShape(bodies[name], -1, rgbaColor=[*colour_rgb01(colour), 1.0],
                                 physicsClientId=cid)
            return
