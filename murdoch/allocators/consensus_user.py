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

import logging
import threading
from collections import deque
from collections.abc import Iterable
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
from murdoch.auction.messages import AuctionEvent, Outcome, TaskSpec
from murdoch.consensus.async_runner import ConsensusChunk
from murdoch.execution.user_side import (
    AT_ONCE_S,
    Lease,
    LeaseStep,
    next_attempt,
    no_winner,
    on_report,
    outcome,
)
from murdoch.subjects import SubjectSet
from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)

OFFER_REPEAT_S = 10.0
CLAIM_KEPT_S = 2.0 * CLAIM_RETRY_S
"""A member's claim of a group offer counts this long (members repeat unanswered claims
every `CLAIM_RETRY_S`)."""


@dataclass
class _Task:
    task_id: str
    spec: TaskSpec
    deadline: float | None
    attempt: int = 0
    phase: str = "waiting"  # offered, granted, waiting
    offer: TaskOffer | None = None
    unwon_since: float = 0.0
    wake_at: float = 0.0
    winner: str | None = None
    lease: Lease | None = None
    no_bid_rounds: int = 0
    last_reason: str = ""
    place: tuple[float, float] = (0.0, 0.0)
    repeats: list[float] = field(default_factory=list)
    claims: dict[str, tuple[float, SeatClaim]] = field(default_factory=dict)
    """A group offer's claims: robot -> (when, claim)."""
    seats: dict[str, int] = field(default_factory=dict)
    """A granted group: robot -> its seat."""
    heard: dict[str, float] = field(default_factory=dict)
    done: set[str] = field(default_factory=set)


class ConsensusUser:
    """The runner's `TeamMember` for a CBBA or CBGA team."""

    def __init__(self, transport: Transport, clock: Clock, hooks: UserHooks) -> None:
        self.transport = transport
        self.clock = clock
        self.hooks = hooks
        self.agent_id = hooks.agent_id
        inst = transport.instance
        self._prefix = f"{hooks.agent_id}.{inst[:6]}" if inst else hooks.agent_id
        self._counter = 0
        self._offers = 0
        self._tasks: dict[str, _Task] = {}
        self._by_offer: dict[int, _Task] = {}
        self._views: dict[int, tuple[float, dict[int, frozenset[int]]]] = {}
        """Per agent index: when last heard, and the offers its state gives winners (the
        agents holding bids)."""
        self._lock = threading.RLock()
        self.outcomes: deque[Outcome] = deque(maxlen=1024)
        """The latest outcomes of the tasks this member introduced."""
        self._sub = transport.subscribe({TEAM_SUBJECT, STATE_SUBJECT})
        self.closed = False

    # -- the user executes nothing and offers no capabilities
    @property
    def subjects(self) -> SubjectSet:
        return frozenset()

    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        if subjects:
            raise ValueError("the user of a consensus team executes no tasks")

    @property
    def executing(self) -> str | None:
        return None

    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        pass

    def complete(self, task_id: str, note: str = "") -> None:
        pass

    def fail(self, task_id: str, reason: str) -> None:
        pass

    def abandon(self, task_id: str, reason: str) -> None:
        pass

    # -- tasks
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str:
        with self._lock:
            now = self.clock()
            self._counter += 1
            task_id = f"{self._prefix}.{self._counter}"
            task = _Task(task_id, spec, None if patience_s is None else now + patience_s,
                         place=self.hooks.locate(spec.name, spec.params))
            self._tasks[task_id] = task
            self._offer(task, now)
            return task_id

    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        with self._lock:
            task = self._tasks.get(task_id)
            if task is not None:
                self._finish(task, self.clock(), "failed", reason)

    def open_tasks(self) -> tuple[str, ...]:
        return tuple(self._tasks)

    # -- the loop
    def step(self, timeout_s: float = 0.0) -> int:
        with self._lock:
            if self.closed:
                return 0
            self.transport.poll(timeout_s)
            envelopes = self._sub.drain()
            now = self.clock()
            for envelope in envelopes:
                self._handle(envelope.message, now)
            for task in list(self._tasks.values()):
                self._tick(task, now)
            return len(envelopes)

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self.closed = True
                self._sub.close()

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
            if task.winner != msg.robot or task.lease is None:
                return
            task.lease.last_heard = now
            meaning = on_report(msg.status)
            if meaning == "end":
                self._finish(task, now, msg.status, msg.reason or msg.status)
            elif meaning == "reoffer":
                self._reallocate(task, now, f"winner {msg.robot} {msg.status}: {msg.reason}",
                                 AT_ONCE_S)

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
                self._no_bid(task, now)
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

    def _lease_ended(self, task: _Task, step: LeaseStep, now: float) -> bool:
        """Act on a lease's step; whether it ended the grant (else: renew it)."""
        if step.kind == "expired":
            self._finish(task, now, "failed", step.reason)
        elif step.kind == "silent":
            self._reallocate(task, now, step.reason, step.wait_s)
        return step.kind != "renew"

    def _offer(self, task: _Task, now: float) -> None:
        spec = task.spec
        gave_up = next_attempt(task.attempt, spec)
        if gave_up is not None:
            task.winner = None
            task.phase = "waiting"
            self._finish(task, now, "failed", gave_up)
            return
        task.attempt += 1
        task.phase = "offered"
        task.winner = None
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
        task.phase = "granted"
        task.winner = claim.robot
        task.lease = Lease.grant(claim.robot, now, task.spec)
        self._emit(now, "close", task, bids=1)
        self._emit(now, "award", task, winner=claim.robot, score=claim.bid, bids=1)
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

    def _no_bid(self, task: _Task, now: float) -> None:
        self._emit(now, "close", task, bids=0)
        self._withdraw(task, "no winner")
        task.no_bid_rounds += 1
        backoff = self.hooks.backoff
        verdict = no_winner(now, task.spec, task.attempt, task.no_bid_rounds, task.last_reason,
                            task.deadline, backoff.delay_s)
        if verdict.retry_in_s is not None:
            task.phase = "waiting"
            task.wake_at = now + verdict.retry_in_s
            self._emit(now, "retry", task, delay_s=verdict.retry_in_s, reason=verdict.reason)
            return
        task.winner = None
        self._finish(task, now, "unachievable", verdict.final_reason)

    def _reallocate(self, task: _Task, now: float, reason: str, wait_s: float) -> None:
        self._emit(now, "reallocation", task, winner=task.winner, reason=reason)
        self._withdraw(task, reason)
        task.last_reason = reason
        task.phase = "waiting"
        task.wake_at = now + wait_s

    def _finish(self, task: _Task, now: float, status: str, reason: str) -> None:
        self._tasks.pop(task.task_id, None)
        if task.phase in ("offered", "granted"):
            self._withdraw(task, reason)
        ended = outcome(task.task_id, task.spec, status, reason, task.winner, task.attempt, now)
        self.outcomes.append(ended)
        self._emit(now, "outcome", task, status=status, reason=reason, winner=ended.winner)

    def _publish(self, subject: str, message: object) -> None:
        try:
            self.transport.publish({subject}, message)
        except OSError as exc:
            log.warning("could not send %s: %s", type(message).__name__, exc)

    def _emit(self, now: float, kind: str, task: _Task, **detail: object) -> None:
        if self.hooks.observer is not None:
            self.hooks.observer(AuctionEvent(now, self.agent_id, kind, task.task_id,
                                             task.attempt, dict(detail)))
