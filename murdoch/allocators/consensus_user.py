"""The user's side of a CBBA or CBGA team: offers tasks, grants claims, watches executors.

The runner introduces each task as the user does under MURDOCH (`announce`, with patience
for reintroduction). Here it *offers* the task on the bus (`TaskOffer`, repeated every
`OFFER_REPEAT_S` so that a robot started later learns it) and the robots plan over it by
consensus. The user listens to their consensus state too: an offer that nobody's view gives
a winner for a whole bid window closes without a bid (the robots that could do it are
charging, dead or lack the devices), and is offered again after a randomized backoff until
its patience runs out, then it is `unachievable`, exactly as an auction without bids. The
first claim the user acts on for a live offer gets it (`TaskGrant`, the award); the executor
must report at least every contract timeout, or the task is revoked (`TaskWithdraw`) and
offered again once the silent robot would have given it up. A report of completion or
failure ends the task. The user repeats its grant every renewal period (the executor gives
the task up when the repeats stop, so after a revocation it missed the two never overlap);
an abandoned task is offered again at once.

A group task (its parameters in the group format, `group_offers`; only the coordinator of an
allocator with `group_tasks` introduces one) is offered whole. It counts as won while some
agent's view holds a full group for it; the user waits for a `SeatClaim` from each member,
hands the seats out (`group_offers.seat_plan`) and grants each its seat (`SeatGrant`, one
award event per seat). Each member reports on its own; the task completes when every seat
has, fails when one fails, and is offered again whole when a member abandons it or falls
silent (the others are stopped by the withdrawal). Every step is reported
to the observer as the auctioneer's events are (announce, close, award, reallocation,
outcome), so a run's events read the same under every allocator.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from murdoch.allocators.base import UserHooks
from murdoch.allocators.consensus_robot import CLAIM_RETRY_S, SILENT_S
from murdoch.allocators.group_offers import is_group, required, seat_plan
from murdoch.allocators.team_messages import (
    SESSION,
    STATE_SUBJECT,
    TEAM_SUBJECT,
    SeatClaim,
    SeatGrant,
    TaskClaim,
    TaskGrant,
    TaskOffer,
    TaskReport,
    TaskWithdraw,
)
from murdoch.auction.messages import TaskSpec
from murdoch.consensus.async_runner import ConsensusChunk
from murdoch.execution.task_user import TaskUser, UserTask
from murdoch.execution.user_side import (
    Lease,
)
from murdoch.transport import Clock, Transport

OFFER_REPEAT_S = 10.0
CLAIM_KEPT_S = 2.0 * CLAIM_RETRY_S
"""A member's claim of a group offer counts this long (members repeat unanswered claims
every `CLAIM_RETRY_S`)."""


@dataclass(kw_only=True)
class _Task(UserTask):
    """A task as this user keeps it (phases: offered, granted, waiting)."""

    offer: TaskOffer | None = None
    unwon_since: float = 0.0
    place: tuple[float, float] = (0.0, 0.0)
    repeats: list[float] = field(default_factory=list)
    claims: dict[str, tuple[float, SeatClaim]] = field(default_factory=dict)
    """A group offer's claims: robot -> (when, claim)."""
    seats: dict[str, int] = field(default_factory=dict)
    """A granted group: robot -> its seat."""
    heard: dict[str, float] = field(default_factory=dict)
    done: set[str] = field(default_factory=set)


class ConsensusUser(TaskUser[_Task]):
    """The runner's `TeamMember` for a CBBA or CBGA team."""

    TEAM = "a consensus team"

    def __init__(self, transport: Transport, clock: Clock, hooks: UserHooks) -> None:
        self.agent_id = hooks.agent_id
        self._views: dict[int, tuple[float, dict[int, frozenset[int]]]] = {}
        """Per agent index: when last heard, and the offers its state gives winners (the
        agents holding bids)."""
        super().__init__(transport, clock, hooks, {TEAM_SUBJECT, STATE_SUBJECT})

    def _new_task(self, task_id: str, spec: TaskSpec, deadline: float | None,
                  place: tuple[float, float], now: float) -> _Task:
        return _Task(task_id, spec, deadline, place=place)

    def _introduce(self, task: _Task, now: float) -> None:
        self._offer(task, now)

    # -- internals
    def _handle(self, msg: object, now: float) -> None:
        if isinstance(msg, ConsensusChunk):
            if msg.session == SESSION:
                _, won = self._views.get(msg.sender, (now, {}))
                lo, hi = msg.first_task, msg.first_task + msg.task_count
                kept = {o: ms for o, ms in won.items() if not lo <= o < hi}
                fresh: dict[int, set[int]] = {}
                for o, m, _ in msg.entries:
                    fresh.setdefault(o, set()).add(m)
                kept.update((o, frozenset(ms)) for o, ms in fresh.items())
                self._views[msg.sender] = (now, kept)
        elif isinstance(msg, TaskClaim):
            task = self._by_offer.get(msg.offer)
            if task is None or task.phase != "offered" or task.task_id != msg.task_id:
                return
            assert task.offer is not None
            if not is_group(task.offer):
                self._grant(task, msg, now)
            elif isinstance(msg, SeatClaim):
                task.claims[msg.robot] = (now, msg)
                self._try_seats(task, now)
        elif isinstance(msg, TaskReport):
            task = self._by_offer.get(msg.offer)
            if task is None or task.phase != "granted":
                return
            if task.seats:
                self._group_report(task, msg, now)
                return
            if task.winner == msg.robot and task.lease is not None:
                self._reported(task, msg, now)

    def _winner_seen(self, offer: TaskOffer, now: float) -> bool:
        """Whether some agent heard lately gives the offer a full set of winners."""
        need = required(offer)
        return any(len(won.get(offer.offer, ())) >= need and now - t <= SILENT_S
                   for t, won in self._views.values())

    def _tick(self, task: _Task, now: float) -> None:
        spec = task.spec
        if task.phase == "waiting":
            if now >= task.wake_at:
                self._offer(task, now)
        elif task.phase == "offered":
            assert task.offer is not None
            if self._winner_seen(task.offer, now):
                task.unwon_since = now
            elif now - task.unwon_since >= spec.bid_window_s:
                self._no_winner(task, now)
            elif now - task.offer.offered_at >= OFFER_REPEAT_S * (len(task.repeats) + 1):
                task.repeats.append(now)
                self._publish(TEAM_SUBJECT, task.offer)
        elif task.phase == "granted" and task.seats:
            self._group_tick(task, now)
        elif task.phase == "granted":
            assert task.lease is not None
            step = task.lease.check(spec, now)
            if step is not None and not self._lease_ended(task, step, now):
                assert task.offer is not None and task.winner is not None
                self._publish(TEAM_SUBJECT, TaskGrant(task.task_id, task.offer.offer,
                                                      task.winner))

    def _offer(self, task: _Task, now: float) -> None:
        spec = task.spec
        if not self._next_attempt(task, now):
            return
        task.phase = "offered"
        task.unwon_since = now
        task.repeats = []
        task.claims, task.seats, task.heard, task.done = {}, {}, {}, set()
        offer = TaskOffer(task.task_id, self._offers, spec.name, tuple(sorted(spec.subjects)),
                          spec.params, spec.duration_s, task.place[0], task.place[1], now)
        self._offers += 1
        task.offer = offer
        self._by_offer[offer.offer] = task
        self._emit(now, "announce", task, name=spec.name, subjects=sorted(spec.subjects),
                   offer=offer.offer)
        self._publish(TEAM_SUBJECT, offer)

    def _withdraw(self, task: _Task, reason: str) -> None:
        if task.offer is not None:
            self._by_offer.pop(task.offer.offer, None)
            self._publish(TEAM_SUBJECT, TaskWithdraw(task.task_id, task.offer.offer, reason))

    def _grant(self, task: _Task, claim: TaskClaim, now: float) -> None:
        self._granted(task, claim.robot, now, 1, claim.bid)
        self._publish(TEAM_SUBJECT, TaskGrant(task.task_id, claim.offer, claim.robot))

    # -- group offers
    def _try_seats(self, task: _Task, now: float) -> None:
        """Grant the seats once the fresh claims fill them all."""
        assert task.offer is not None
        task.claims = {r: c for r, c in task.claims.items() if now - c[0] <= CLAIM_KEPT_S}
        plan = seat_plan(task.offer, [c for _, c in task.claims.values()])
        if plan is None:
            return
        bids = {r: c.bid for r, (_, c) in task.claims.items()}
        task.phase = "granted"
        task.seats = dict(sorted(plan.items(), key=lambda rs: rs[1]))
        task.winner = next(iter(task.seats))
        task.heard = {r: now for r in task.seats}
        task.done = set()
        task.lease = Lease.grant(task.winner, now, task.spec)
        self._emit(now, "close", task, bids=len(task.claims))
        for robot, seat in task.seats.items():
            self._emit(now, "award", task, winner=robot, score=bids[robot], bids=len(bids),
                       seat=seat)
        task.claims = {}
        self._send_seats(task)

    def _send_seats(self, task: _Task) -> None:
        assert task.offer is not None
        for robot, seat in task.seats.items():
            if robot not in task.done:
                self._publish(TEAM_SUBJECT, SeatGrant(task.task_id, task.offer.offer, robot,
                                                      seat))

    def _group_report(self, task: _Task, msg: TaskReport, now: float) -> None:
        if msg.robot not in task.seats or msg.robot in task.done:
            return
        task.heard[msg.robot] = now
        if msg.status == "completed":
            task.done.add(msg.robot)
            if len(task.done) == len(task.seats):
                self._finish(task, now, "completed", msg.reason or "completed")
        elif msg.status == "failed":
            task.winner = msg.robot
            self._finish(task, now, "failed", msg.reason or "failed")
        elif msg.status == "abandoned":
            task.winner = msg.robot
            self._reallocate(task, now, f"member {msg.robot} abandoned: {msg.reason}", 0.0)

    def _group_tick(self, task: _Task, now: float) -> None:
        spec = task.spec
        silent = sorted(r for r, t in task.heard.items()
                        if r not in task.done and now - t > spec.contract_timeout_s)
        assert task.lease is not None
        step = task.lease.check(spec, now, f"member {silent[0]}" if silent else None,
                                task.heard[silent[0]] if silent else now)
        if step is not None and step.kind == "silent":
            task.winner = silent[0]
        if step is not None and not self._lease_ended(task, step, now):
            self._send_seats(task)

    def _release(self, task: _Task, reason: str) -> None:
        if task.phase in ("offered", "granted"):
            self._withdraw(task, reason)
