"""The per-tick sensing pass: the range sensors and blobfinders read in a tick, together.

The first reading of a range sensor or a blobfinder in a tick computes the readings of every
one expected to be read in that tick (`RangeModel.reads`, `CameraModel.reads`: those read
every tick, those read every k ticks when their turn comes; `read_schedule`) in one go, and
the world caches them until the next tick; one read when it was not expected is computed
then. In the fast fidelity that is one batched ray cast of
the range sensors' rays and the blobfinders' occlusion rays; in the render fidelity each
model renders its own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from player_server.sim.cast_kernel import CompiledCaster

if TYPE_CHECKING:
    from player_server.sim.devices.camera import CameraModel
    from player_server.sim.devices.ranging import RangeModel
    from player_server.sim.devices.world import DeviceWorld
    from player_server.sim.tick_arrays import TickArrays
    from player_server.sim.timings import Timings


@dataclass(eq=False, repr=False)
class SensingPass:
    """The pass of one world (its cache, fidelity and fixed arrays), over its two sensing
    models; `clock`, when given, times the pass into `timings`."""

    world: DeviceWorld
    ranging: RangeModel
    camera: CameraModel
    tick_arrays: TickArrays
    clock: Callable[[], float] | None
    timings: Timings
    caster: CompiledCaster = field(init=False, default_factory=CompiledCaster)
    #: the world's cache key of this tick's readings (the fidelity is fixed)
    key: tuple[str, str] = field(init=False)
    _zeros: np.ndarray = field(init=False, default_factory=lambda: np.zeros(256))

    def __post_init__(self) -> None:
        self.key = ("sensed", self.world.fidelity)

    def sensed(self) -> dict[str, dict[Any, Any]]:
        """This tick's readings of the range sensors and blobfinders expected in it,
        computed together on first use."""
        cache = self.world.cached(self.key, lambda: {"ranges": {}, "blobs": {}})
        assert isinstance(cache, dict)
        tick = self.world.tick
        rkeys = self.ranging.reads.expected(tick)
        if cache["ranges"]:
            rkeys = tuple(k for k in rkeys if k not in cache["ranges"])
        cams = list(self.camera.reads.expected(tick))
        if cache["blobs"]:
            cams = [i for i in cams if i not in cache["blobs"]]
        if rkeys or cams:
            if self.world.fidelity == "render":
                self._render(rkeys, cams, cache)
            else:
                self._fast(rkeys, cams, cache)
        return cache

    def warm(self) -> None:
        """Compile, or load from numba's disk cache, every kernel the fast pass calls (the ray
        casts with and without the footprint grid, the blobfinders' pending pairs and boxes),
        by one pass over every range sensor and blobfinder of the world on its own arrays,
        so that the first round a client asks for does not wait seconds for a compiler on a
        fresh clone. Keeps nothing: no reading is cached and no read is noted. The
        render fidelity has nothing to compile."""
        if self.world.fidelity != "fast":
            return
        robots = self.world.spec.robots
        rkeys = tuple((i, kind) for i, r in enumerate(robots) for kind in self.ranging.kinds
                      if getattr(r.devices, kind, None) is not None)
        cams = [i for i, r in enumerate(robots) if r.devices.blobfinder is not None]
        rays, *_ = self._rays(rkeys, cams)
        if rays is not None:
            o, d, limit, z, own = rays
            fp, room = self.tick_arrays.footprints(), self.world.arrays.room
            for grid_min in (0, fp.count + 1):  # with the grid, and without
                CompiledCaster(grid_min, split_min=o.size + 1).cast(o, d, limit, z, fp, room,
                                                                    own)
        # numba types an array of one element (or none) as contiguous, whatever its strides:
        # one camera and one pair give other signatures than several
        _pan, tilt, zoom = self.world.ptz_arrays()
        for some in (cams, cams[:1]) if cams else ():
            bplan, pending = self.camera.fast_pending(some, self.tick_arrays.frame())
            for pairs in ([0, 0], [0]) if pending.slot.size else ([],):
                bplan.boxes(pending, np.array(pairs, dtype=np.int64), tilt, zoom)

    def _now(self) -> float:
        return self.clock() if self.clock is not None else 0.0

    def _zeros_for(self, n: int) -> np.ndarray:
        if self._zeros.size < n:
            self._zeros = np.zeros(max(n, 2 * self._zeros.size))
        return self._zeros[:n]

    def _fast(self, rkeys: tuple[tuple[int, str], ...], cams: list[int],
              cache: dict[str, dict[Any, Any]]) -> None:
        w = self.world
        t0 = self._now()
        rays, plan, bplan, pending = self._rays(rkeys, cams)
        n_range = 0 if plan is None else plan.max_range.size
        t1 = self._now()
        hits = np.zeros(0)
        if rays is not None:
            o, d, limit, z, own = rays
            hits = self.caster.cast(o, d, limit, z, self.tick_arrays.footprints(),
                                    w.arrays.room, own)
        t2 = self._now()
        if plan is not None:
            cache["ranges"].update(self.ranging.fast_readings(plan, hits[:n_range]))
        t3 = self._now()
        if bplan is not None and pending is not None:
            visible = hits[n_range:] >= pending.near - 0.05
            cache["blobs"].update(self.camera.fast_blobs(cams, bplan, pending, visible))
        if self.clock is not None:
            t4 = self._now()
            share = n_range / max(1, hits.size)
            self.timings.ranges_s += (t3 - t2) + (t2 - t1) * share
            self.timings.blobs_s += (t1 - t0) + (t4 - t3) + (t2 - t1) * (1 - share)

    def _rays(self, rkeys: tuple[tuple[int, str], ...], cams: list[int]) -> tuple[
            tuple[np.ndarray, ...] | None, Any, Any, Any]:
        """The batch of one fast pass: the rays (origins, directions, limits, heights, own
        footprints; the range sensors' first, then the blobfinders' occlusion rays; None for
        no ray), the range plan and the blob plan with its pending pairs (None without)."""
        frame = self.tick_arrays.frame()
        origins: list[np.ndarray] = []
        dirs: list[np.ndarray] = []
        maxr: list[np.ndarray] = []
        zs: list[np.ndarray] = []
        own: list[np.ndarray] = []
        plan = None
        if rkeys:
            plan = self.ranging.plan(rkeys)
            o, d = plan.rays(frame)
            origins.append(o)
            dirs.append(d)
            maxr.append(plan.max_range)
            zs.append(plan.z)
            own.append(plan.own)
        bplan = pending = None
        if cams:
            bplan, pending = self.camera.fast_pending(cams, frame)
            if pending.slot.size:
                # Occlusion: the ray from the camera to the target's centre must reach the
                # target's near side (cast at ground level: every footprint can block it).
                origins.append(pending.origin)
                dirs.append(pending.direction)
                maxr.append(pending.dist)
                zs.append(self._zeros_for(pending.slot.size))
                own.append(bplan.own[pending.slot])
        if not origins:
            return None, plan, bplan, pending
        rays = tuple(np.concatenate(parts) if len(parts) > 1 else parts[0]
                     for parts in (origins, dirs, maxr, zs, own))
        return rays, plan, bplan, pending

    def _render(self, rkeys: tuple[tuple[int, str], ...], cams: list[int],
                cache: dict[str, dict[Any, Any]]) -> None:
        t0 = self._now()
        if rkeys:
            cache["ranges"].update(self.ranging.render(rkeys, self.tick_arrays.frame()))
        t1 = self._now()
        if cams:
            cache["blobs"].update(self.camera.render(cams))
        if self.clock is not None:
            self.timings.ranges_s += t1 - t0
            self.timings.blobs_s += self._now() - t1
