"""Range sensors (sonar rings, lasers, rangers), in both fidelities.

fast: every active sensor's rays are cast in one batch against the world's 2-D footprints
(with the blobfinders' occlusion rays, `player_server.sim.sensing`); render: PyBullet rays at
the sensor's height. A reading equal to the last one of the same sensor is handed out as the
same (read-only) array, so that readers can tell by identity that it has not changed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
import pybullet as pb
from numpy.typing import NDArray

from player_server.sim.devices.base import StatelessModel
from player_server.sim.fastsense import Frame, RangePlan
from player_server.sim.read_schedule import ReadSchedule

if TYPE_CHECKING:
    from player_server.sim.devices.world import DeviceWorld

RangeKey = tuple[int, str]
"""(robot index, device kind)"""


class RangeModel(StatelessModel):
    kinds: ClassVar[tuple[str, ...]] = ("sonar", "laser", "ranger")
    order: ClassVar[int] = 60

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world
        self.reads: ReadSchedule[RangeKey] = ReadSchedule()  # which a sensing pass casts for
        # lasers and rangers cast at angles of their own (first, spacing, count; `set_fan`),
        # kept across rebuilds (a reset): they are the configuration their drivers hold
        self.fans: dict[RangeKey, tuple[float, float, int]] = {}

    def build(self) -> None:
        self.plans: dict[tuple[RangeKey, ...], RangePlan] = {}
        self.last: dict[RangeKey, np.ndarray] = {}  # cleared by a reader: every reading afresh
        # the plan of the last fast batch and its readings' bits (see `fast_readings`)
        self._last_batch: tuple[RangePlan, NDArray[np.uint32]] | None = None

    def reading(self, robot: str, kind: str) -> np.ndarray:
        w = self.world
        st = w.device(robot, kind)
        key = (st.index, kind)
        self.reads.note(key, w.tick)
        done = w.sensed_now()
        if done is not None and key in done["ranges"]:
            return done["ranges"][key]
        return w.sense()["ranges"][key]

    def sonar(self, robot: str) -> NDArray[np.float32]:
        return self.reading(robot, "sonar")

    def laser(self, robot: str) -> NDArray[np.float32]:
        return self.reading(robot, "laser")

    def ranger(self, robot: str) -> NDArray[np.float64]:
        return self.reading(robot, "ranger")

    def plan(self, keys: tuple[RangeKey, ...]) -> RangePlan:
        plan = self.plans.get(keys)
        if plan is None:
            plan = self.plans[keys] = RangePlan.build(keys, self.world.spec.robots,
                                                       self.world.arrays, self.fans)
        return plan

    def set_fan(self, robot: str, kind: str, fan: tuple[float, float, int] | None) -> None:
        """Cast a laser's or ranger's readings at ``first + i * spacing`` (i < count) robot
        frame angles about its mount instead of the world file's (None); this tick's
        readings are made again with it."""
        if kind not in ("laser", "ranger"):
            raise ValueError(f"only a laser or ranger casts a fan, not a {kind}")
        first, spacing, count = fan if fan is not None else (0.0, 1.0, 1)
        if not (np.isfinite(first) and np.isfinite(spacing) and spacing > 0 and count >= 1):
            raise ValueError(f"a fan needs finite angles and a count >= 1, not {fan}")
        key = (self.world.device(robot, kind).index, kind)
        if self.fans.get(key) == fan:
            return
        if fan is None:
            del self.fans[key]
        else:
            self.fans[key] = fan
        self.plans.clear()
        self._last_batch = None
        self.last.pop(key, None)
        self.world.invalidate()

    # -- fast
    def fast_readings(self, plan: RangePlan, hits: np.ndarray) -> dict[RangeKey, np.ndarray]:
        """Per-sensor readings from the batch's hits, the last array kept when equal.

        When the last batch was of the same plan, the last arrays of its sensors hold that
        batch's readings, so one comparison of the two batches' bits tells which sensors
        changed (a ranger's float64 reading is compared on its own).
        """
        r, cones = plan.minima(hits)
        bits = cones.view(np.uint32)
        last = self.last
        lb = self._last_batch
        starts = plan.reading_start
        changed: list[bool] | None = None
        # (a sensor without readings, if any, is compared on its own)
        if (lb is not None and lb[0] is plan and bits.size
                and bool((starts[1:] > starts[:-1]).all())):
            changed = np.logical_or.reduceat(bits != lb[1], starts[:-1]).tolist()
        self._last_batch = (plan, bits)
        fresh: dict[RangeKey, np.ndarray] = {}
        start = plan.reading_start_list
        for i, key in enumerate(plan.keys):
            old = last.get(key)
            if key[1] == "ranger" or changed is None:
                new = plan.reading(i, r, cones)
                if (old is not None and old.dtype == new.dtype
                        and old.tobytes() == new.tobytes()):
                    fresh[key] = old
                else:
                    fresh[key] = last[key] = new
            elif changed[i] or old is None:
                # `plan.reading` of a sensor that is not a ranger, written out
                new = cones[start[i]:start[i + 1]].copy()
                new.setflags(write=False)
                fresh[key] = last[key] = new
            else:
                fresh[key] = old
        return fresh

    # -- render
    def render(self, keys: tuple[RangeKey, ...], frame: Frame) -> dict[RangeKey, np.ndarray]:
        plan = self.plan(keys)
        o, d = plan.rays(frame)
        return plan.split(self._render_rays(plan, o, d, frame))

    def _render_rays(self, plan: RangePlan, o: np.ndarray, d: np.ndarray,
                     frame: Frame) -> np.ndarray:
        """PyBullet rays at the sensor height, starting where each ray leaves its own body."""
        w = self.world
        r = plan.robot
        head = frame.head[r]
        body = frame.pos[r] + head * w.robot_offset[r]
        half_l = w.arrays.rect_half_x[r]
        half_w = w.arrays.rect_half_y[r]
        # Ray origin and direction in the body frame; slab exit distance of the body box.
        p = (o - body) * head.conjugate()
        q = d * head.conjugate()
        px, py, qx, qy = p.real, p.imag, q.real, q.imag
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(np.abs(qx) > 1e-12, (np.sign(qx) * half_l - px) / qx, np.inf)
            ty = np.where(np.abs(qy) > 1e-12, (np.sign(qy) * half_w - py) / qy, np.inf)
        inside = (np.abs(px) <= half_l) & (np.abs(py) <= half_w)
        skip = np.where(inside, np.maximum(np.minimum(tx, ty), 0.0) + 1e-3, 0.0)
        wa = w.arrays
        for k, robot in enumerate(wa.outline_robot.tolist()):  # bodies with an outline
            rows = np.flatnonzero(r == robot)
            if rows.size:
                out_of = _outline_exit(p[rows], q[rows], wa.outline_local[
                    wa.outline_start[k]:wa.outline_start[k + 1]])
                # (past the convex mesh's collision margin, about 1 mm outside it)
                skip[rows] = np.where(np.isfinite(out_of), out_of + 3e-3, 0.0)
        ox, oy, dx, dy = o.real, o.imag, d.real, d.imag
        max_r = plan.max_range
        z = plan.z
        frm = np.stack([ox + dx * skip, oy + dy * skip, z], axis=1).tolist()
        to = np.stack([ox + dx * max_r, oy + dy * max_r, z], axis=1).tolist()
        out = np.array(max_r, copy=True)
        batch = 16000
        cid = w.physics_client
        for i in range(0, len(frm), batch):
            res = pb.rayTestBatch(frm[i:i + batch], to[i:i + batch], physicsClientId=cid)
            for j, hit in enumerate(res):
                if hit[0] >= 0:
                    k = i + j
                    out[k] = skip[k] + hit[2] * (max_r[k] - skip[k])
        return out


def _outline_exit(p: np.ndarray, q: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """Where rays (origins p, directions q, in the body's frame about its centre) leave a
    convex anticlockwise outline: inf for a ray starting outside it."""
    e = np.roll(outline, -1) - outline
    nrm = -1j * e  # outwards
    rel = outline[None, :] - p[:, None]
    num = rel.real * nrm.real + rel.imag * nrm.imag  # >= 0 on the inner side of an edge
    den = q.real[:, None] * nrm.real + q.imag[:, None] * nrm.imag
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den > 0.0, num / den, np.inf)
    return np.where((num >= 0.0).all(axis=1), t.min(axis=1), np.inf)
