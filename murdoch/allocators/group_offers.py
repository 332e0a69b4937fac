"""Group offers: one task that needs several robots at once, offered whole (pure).

A consensus allocator that forms coalitions (CBGA, `Allocator.group_tasks`) is offered a
group task as one `TaskOffer` whose `params` are the group format of the long-term domain
(`docs/allocators.md`, "What a group task needs, as data"): `required` robots, and for each
one a *seat* in `members` (`kind`: the single-robot task the seat runs, `equipment`: the
resources it needs, `params`: that task's parameters). A plain offer has one seat: its own
name, subjects and parameters.

A robot may bid on a group offer when it can fill at least one seat (the seat's equipment
among its subjects, the seat's kind in its library). When its consensus view holds a full
group with itself in it, it claims the offer with a `SeatClaim` (the seats it can fill and
where it stands); the user waits for a claim from every member, hands the seats out with
`seat_plan` (each robot a seat it can fill, the least total straight-line distance to the
seats' places) and sends each member a `SeatGrant`.

`offer_problem` is the one check of an offer a robot hears: anything else is refused and
counted, never planned over.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from murdoch.allocators.team_messages import SeatClaim, TaskOffer

MAX_SEATS = 4
"""The most robots one group offer may need."""
MAX_CLAIMANTS = 8
"""The claims a group's seats are handed out among (the strongest bids first)."""


@dataclass(frozen=True)
class Seat:
    """One place in a task: the single-robot task it runs, what it needs, its parameters."""

    kind: str
    equipment: frozenset[str]
    params: Mapping[str, Any]


def is_group(offer: TaskOffer) -> bool:
    return "members" in offer.params


def seats(offer: TaskOffer) -> tuple[Seat, ...]:
    """The offer's seats (one for a plain offer). The offer must have passed
    `offer_problem`."""
    if not is_group(offer):
        return (Seat(offer.name, frozenset(offer.subjects), offer.params),)
    return tuple(Seat(str(m["kind"]), frozenset(m["equipment"]), m["params"])
                 for m in offer.params["members"])


def required(offer: TaskOffer) -> int:
    """How many robots the offer needs at once."""
    return len(offer.params["members"]) if is_group(offer) else 1


def seat_place(offer: TaskOffer, seat: Seat) -> tuple[float, float]:
    """Where a seat is done: a group seat's own `x`, `y` when its parameters give them,
    else the offer's place (always, for a plain offer: the user located it)."""
    x, y = seat.params.get("x"), seat.params.get("y")
    if is_group(offer) and _number(x) and _number(y):
        return (float(x), float(y))  # type: ignore[arg-type]
    return (offer.x, offer.y)


def fillable(offer: TaskOffer, subjects: frozenset[str],
             knows: Callable[[str], bool]) -> tuple[int, ...]:
    """The seats a robot with these subjects and this library can fill."""
    return tuple(k for k, s in enumerate(seats(offer))
                 if s.equipment <= subjects and knows(s.kind))


def _number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _names(v: object) -> bool:
    return isinstance(v, list | tuple) and all(isinstance(s, str) and s for s in v)


def offer_problem(offer: TaskOffer, *, team_size: int, groups: bool) -> str | None:
    """What is wrong with an offer a robot heard (None: nothing). `groups`: whether this
    robot's allocator takes group offers."""
    if offer.offer < 0:
        return f"offer number {offer.offer} is negative"
    if offer.duration_s < 0:
        return f"duration {offer.duration_s:g} s is negative"
    if not is_group(offer):
        return None
    if not groups:
        return "a group offer, and this allocator gives tasks to single robots"
    members = offer.params["members"]
    if not isinstance(members, list | tuple) or not 2 <= len(members) <= MAX_SEATS:
        return f"expected 2 to {MAX_SEATS} members, found {_shown(members)}"
    if len(members) > team_size:
        return f"needs {len(members)} robots, the team has {team_size}"
    if offer.params.get("required", len(members)) != len(members):
        return (f"required {_shown(offer.params.get('required'))} but "
                f"{len(members)} members")
    for k, m in enumerate(members):
        if not isinstance(m, Mapping):
            return f"member {k}: expected an object, found {_shown(m)}"
        if not isinstance(m.get("kind"), str) or not m["kind"]:
            return f"member {k}: expected a task kind, found {_shown(m.get('kind'))}"
        if not _names(m.get("equipment")):
            return f"member {k}: expected equipment names, found {_shown(m.get('equipment'))}"
        if not isinstance(m.get("params"), Mapping):
            return f"member {k}: expected params, found {_shown(m.get('params'))}"
    return None


def _shown(v: object) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def seat_plan(offer: TaskOffer, claims: Sequence[SeatClaim]) -> dict[str, int] | None:
    """Robot -> seat for the offer's seats among these claims (one claim per robot), or
    None when no set of claimants fills every seat. Each robot gets a seat it said it can
    fill; among the ways to fill them, the least total straight-line distance from where
    each claimant stood to its seat's place wins (equal: the first in robot-name order).
    At most `MAX_CLAIMANTS` claims are considered, the strongest bids first."""
    places = [seat_place(offer, s) for s in seats(offer)]
    n = len(places)
    ranked = sorted(claims, key=lambda c: (-c.bid, c.robot))[:MAX_CLAIMANTS]
    ranked.sort(key=lambda c: c.robot)
    best: tuple[float, tuple[str, ...]] | None = None
    for chosen in itertools.permutations(ranked, n):
        if any(k not in c.seats for k, c in enumerate(chosen)):
            continue
        cost = sum(math.hypot(c.x - px, c.y - py)
                   for c, (px, py) in zip(chosen, places, strict=True))
        key = (cost, tuple(c.robot for c in chosen))
        if best is None or key < best:
            best = key
    if best is None:
        return None
    return {robot: k for k, robot in enumerate(best[1])}
