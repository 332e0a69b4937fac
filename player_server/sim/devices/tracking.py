"""Fiducial detectors on robots and the overhead camera's tracking of every body in view."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from player_server.sim.devices.base import StatelessModel
from player_server.sim.drive import wrap_angle
from player_server.sim.readings import BodyPose, Fiducial, TrackedObject, fast_constructor

_make_tracked = fast_constructor(TrackedObject)


class TrackingModel(StatelessModel):
    kinds: ClassVar[tuple[str, ...]] = ("fiducial",)
    order: ClassVar[int] = 80
    """(and the world's overhead camera, which is not a robot's device)"""

    def build(self) -> None:
        self._colours: dict[str, int] | None = None
        self._looks = 0  # the `Looks.version` of `_colours`
        # the last pose of each body the overhead camera saw, and what it made of it
        self._seen: dict[str, tuple[BodyPose, TrackedObject]] = {}

    def fiducials(self, robot: str) -> tuple[Fiducial, ...]:
        w = self.world
        st = w.device(robot, "fiducial")
        spec = st.spec.devices.fiducial
        assert spec is not None

        def compute() -> tuple[Fiducial, ...]:
            m = spec.pose
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            sx, sy = st.x + c * m.x - s * m.y, st.y + s * m.x + c * m.y
            syaw = st.yaw + m.yaw
            things: list[tuple[int, float, float, float]] = []
            # only the robots and objects listed near the detector in this tick's grids
            reach = spec.max_range_m + 1e-6
            robots = w.robots
            ids = w.looks.fiducial_id
            for i in w.tick_arrays.robots_near(sx, sy, reach):
                other = robots[i]
                if other is not st and (fid := ids(other.spec.name)) > 0:
                    things.append((fid, other.x, other.y, other.yaw))
            objects = w.spec.objects
            for row in w.tick_arrays.objects_near(sx, sy, reach):
                o = objects[row]
                if (fid := ids(o.name)) > 0 and o.name not in w.hidden:
                    things.append((fid, *w.tick_arrays.dyn_pose(o.name)))
            out = []
            for fid, x, y, yaw in things:
                wx, wy = x - sx, y - sy
                rng = math.hypot(wx, wy)
                bearing = wrap_angle(math.atan2(wy, wx) - syaw)
                if spec.min_range_m <= rng <= spec.max_range_m and \
                        abs(bearing) <= spec.fov_rad / 2:
                    cs, sn = math.cos(syaw), math.sin(syaw)
                    out.append(Fiducial(fid, cs * wx + sn * wy, -sn * wx + cs * wy,
                                        wrap_angle(yaw - syaw), rng, bearing))
            return tuple(sorted(out, key=lambda f: f.range_m))

        return w.cached(("fiducials", st.index), compute)  # type: ignore[return-value]

    def overhead(self) -> tuple[TrackedObject, ...]:
        w = self.world
        oc = w.spec.overhead_camera
        if oc is None:
            raise ValueError(f"world {w.spec.name!r} has no overhead camera")

        def compute() -> tuple[TrackedObject, ...]:
            colours = self._spec_colours()
            noise = None
            if oc.position_noise_m > 0:
                noise = np.random.default_rng([w.noise_seed, w.tick])
            half_x, half_y = oc.view_size_x_m / 2, oc.view_size_y_m / 2
            seen = self._seen
            make = _make_tracked
            out = []
            for bp in w.snapshot().bodies:
                if abs(bp.x - oc.x) > half_x or abs(bp.y - oc.y) > half_y:
                    continue
                if noise is not None:
                    n = noise.standard_normal(2) * oc.position_noise_m
                    out.append(make(bp.name, bp.kind, colours[bp.name], bp.x + float(n[0]),
                                    bp.y + float(n[1]), bp.yaw))
                    continue
                # a body that has not moved keeps its pose object, and its tracked thing
                hit = seen.get(bp.name)
                if hit is None or hit[0] is not bp:
                    hit = seen[bp.name] = (bp, make(bp.name, bp.kind, colours[bp.name], bp.x,
                                                    bp.y, bp.yaw))
                out.append(hit[1])
            return tuple(out)

        return w.cached("overhead", compute)  # type: ignore[return-value]

    def _spec_colours(self) -> dict[str, int]:
        """Name -> colour of every robot, box, object and marker (as they look now)."""
        colours = self._colours
        if colours is None or self._looks != self.world.looks.version:
            self._looks = self.world.looks.version
            self._seen.clear()  # what was made with the old colours
            spec = self.world.looks.applied()
            colours = {r.name: r.colour for r in spec.robots}
            colours.update({b.name: b.colour for b in spec.boxes})
            colours.update({o.name: o.colour for o in spec.objects})
            colours.update({m.name: m.colour for m in spec.markers})
            self._colours = colours
        return colours
