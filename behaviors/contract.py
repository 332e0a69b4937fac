"""The contract every basis behaviour must honour, as a checker run over every behaviour.

- pure: the same (snapshot, now) gives the same proposal, whatever was asked before;
- total: no exception for empty snapshots, missing devices or odd readings (inf, NaN, 0);
- stale data counts as no data: readings older than the behaviour's horizon are ignored;
- bounded: finite numbers, |vx| <= max_speed_mps, |vyaw| <= max_turn_radps, weight in [0, 1],
  and an inactive proposal asks for no motion.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable

from behaviors.proposal import Behaviour, Proposal
from behaviors.snapshot import (
    Blob,
    BlobView,
    Bumpers,
    Gripper,
    Mark,
    Odometry,
    Pose2D,
    Power,
    RangeScan,
    Snapshot,
)

_EPS = 1e-9
STALE_AFTER_S = 100.0


class ContractViolation(AssertionError):
    pass


def _laser(rng: random.Random, t: float, n: int = 181, odd: bool = False) -> RangeScan:
    bearings = tuple(-math.pi / 2 + i * math.pi / (n - 1) for i in range(n))
    ranges = [rng.uniform(0.05, 8.0) for _ in range(n)]
    if odd:
        for i in rng.sample(range(n), 5):
            ranges[i] = rng.choice([0.0, math.inf, 8.0])
    return RangeScan(tuple(ranges), bearings, 8.0, t, scan_id=int(t * 10))


def _sonar(rng: random.Random, t: float) -> RangeScan:
    bearings = tuple(math.radians(a) for a in (90, 50, 30, 10, -10, -30, -50, -90,
                                               -90, -130, -150, -170, 170, 150, 130, 90))
    ranges = tuple(rng.uniform(0.1, 5.0) for _ in bearings)
    return RangeScan(ranges, bearings, 5.0, t, offsets_m=(0.15,) * len(bearings))


def _camera(rng: random.Random, t: float, colours: tuple[int, ...]) -> BlobView:
    blobs = []
    for _ in range(rng.randint(0, 4)):
        left = rng.randint(0, 150)
        right = rng.randint(left, 159)
        top = rng.randint(0, 110)
        bottom = rng.randint(top, 119)
        blobs.append(Blob(rng.choice(colours), (right - left + 1) * (bottom - top + 1),
                          (left + right) / 2, (top + bottom) / 2, left, right, top, bottom,
                          rng.choice([rng.uniform(0.2, 8.0), math.inf])))
    return BlobView(160, 120, tuple(blobs), math.radians(60.0), t)


def random_snapshot(rng: random.Random, time_s: float, colours: tuple[int, ...] = (0xFF0000,),
                    odd: bool = False) -> Snapshot:
    """A snapshot with every device present and plausible (or, with `odd`, awkward) data."""
    pose = Pose2D(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi))
    laser = _laser(rng, time_s, odd=odd)
    return Snapshot(
        time_s=time_s,
        odometry=Odometry(pose, rng.uniform(-0.5, 0.5), rng.uniform(-1, 1),
                          rng.random() < 0.2, time_s),
        sonar=_sonar(rng, time_s),
        laser=laser,
        camera=_camera(rng, time_s, colours),
        bumpers=Bumpers(tuple(rng.random() < 0.2 for _ in range(10)), time_s),
        power=Power(rng.uniform(0, 100), 12.0, rng.choice([-1, 0, 1]), time_s),
        gripper=Gripper(1, 0, 0, time_s),
        mark=Mark(time_s - rng.uniform(0, 5),
                  Pose2D(pose.x_m, pose.y_m, rng.uniform(-math.pi, math.pi)),
                  _laser(rng, time_s, odd=odd) if rng.random() < 0.5 else laser),
    )


def edge_snapshots(time_s: float) -> list[Snapshot]:
    """Empty and degenerate snapshots every behaviour must survive."""
    empty_scan = RangeScan((), (), 0.0, time_s)
    return [
        Snapshot(time_s=time_s),
        Snapshot(time_s=time_s, sonar=empty_scan, laser=empty_scan,
                 camera=BlobView(0, 0, (), 0.0, time_s), bumpers=Bumpers((), time_s),
                 mark=Mark(time_s, None, None)),
        Snapshot(time_s=time_s,
                 odometry=Odometry(Pose2D(math.nan, 0.0, 0.0), 0.0, 0.0, False, time_s),
                 power=Power(math.nan, 0.0, 0, time_s)),
    ]


def _check_bounds(b: Behaviour, p: object, where: str) -> None:
    if not isinstance(p, Proposal):
        raise ContractViolation(f"{b.name}: decide() returned {type(p).__name__}, {where}")
    for label, v in (("vx_mps", p.vx_mps), ("vyaw_radps", p.vyaw_radps),
                     ("weight", p.weight), ("value", p.value)):
        if not isinstance(v, float | int) or (label != "value" and not math.isfinite(v)):
            raise ContractViolation(f"{b.name}: {label}={v!r} is not finite, {where}")
    if abs(p.vx_mps) > b.max_speed_mps + _EPS:
        raise ContractViolation(f"{b.name}: |vx|={p.vx_mps} > {b.max_speed_mps}, {where}")
    if abs(p.vyaw_radps) > b.max_turn_radps + _EPS:
        raise ContractViolation(f"{b.name}: |vyaw|={p.vyaw_radps} > {b.max_turn_radps}, {where}")
    if not 0.0 <= p.weight <= 1.0:
        raise ContractViolation(f"{b.name}: weight {p.weight} outside [0, 1], {where}")
    if not p.active and (p.vx_mps != 0.0 or p.vyaw_radps != 0.0):
        raise ContractViolation(f"{b.name}: inactive proposal asks for motion, {where}")
    if not isinstance(p.signal, str):
        raise ContractViolation(f"{b.name}: signal {p.signal!r} is not a string, {where}")


def check_behaviour(behaviour: Behaviour, snapshots: Iterable[Snapshot]) -> int:
    """Run the contract over `snapshots` (plus edge cases); return the number of checks.

    Raises `ContractViolation` with a description of the first broken rule.
    """
    if not isinstance(behaviour.name, str) or not behaviour.name:
        raise ContractViolation(f"{behaviour!r}: needs a non-empty name")
    if behaviour.max_speed_mps < 0 or behaviour.max_turn_radps < 0:
        raise ContractViolation(f"{behaviour.name}: negative limits")
    cases = list(snapshots)
    checks = 0
    for s in [*cases, *edge_snapshots(cases[0].time_s if cases else 1.0)]:
        now = s.time_s
        where = f"at t={now}"
        try:
            first = behaviour.decide(s, now)
            _check_bounds(behaviour, first, where)
            # Purity: ask again at once, and again after asking about something else.
            repeated = behaviour.decide(s, now)
            behaviour.decide(cases[0] if cases else s, now + 0.05)
            again = behaviour.decide(s, now)
            # Stale data behaves like no data at all.
            late = now + STALE_AFTER_S
            stale = behaviour.decide(s, late)
            blank = behaviour.decide(Snapshot(time_s=s.time_s, mark=s.mark), late)
        except ContractViolation:
            raise
        except Exception as exc:  # the contract is "never raises"
            raise ContractViolation(f"{behaviour.name}: raised {exc!r} {where}") from exc
        if repeated != first or again != first:
            raise ContractViolation(
                f"{behaviour.name}: not deterministic {where}: {first}, {repeated}, {again}"
            )
        _check_bounds(behaviour, stale, where + " (stale)")
        if stale != blank:
            raise ContractViolation(
                f"{behaviour.name}: acts on stale data {where}: {stale} vs no data {blank}"
            )
        _check_inputs_key(behaviour, s, now, first, cases)
        checks += 1
    return checks


def _check_inputs_key(behaviour: Behaviour, s: Snapshot, now: float, first: Proposal,
                      cases: list[Snapshot]) -> None:
    """An `inputs_key` (see `runner`) may only repeat when the proposal does."""
    key_of = getattr(behaviour, "inputs_key", None)
    if not callable(key_of):
        return
    key = key_of(s, now)
    if key is None:
        return
    for other, t in ((s, now + 0.01), (s, now + 0.5), (cases[0] if cases else s, now)):
        if key_of(other, t) == key and behaviour.decide(other, t) != first:
            raise ContractViolation(
                f"{behaviour.name}: same inputs key {key!r} at t={now} and t={t} but "
                f"different proposals")
