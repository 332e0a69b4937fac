"""A robot's CBBA or CBGA member: plans over the user's offers by consensus on the bus.

Each step (once per tick of the robot's loop, on simulation time) the member:

1. takes what the bus brought (in lockstep, the previous tick's datagrams in tick order):
   offers join its task list, grants and withdrawals leave it, neighbours' consensus state
   waits in an inbox;
2. notices silent agents: one that holds bids in its view and has not been heard for
   `SILENT_S` simulated seconds has died (or lost its link), and its bids are dropped
   (`forget_agent`); heard again, it is back;
3. re-plans when its task list, its subjects (none while charging), its silent agents or
   its own task changed: a fresh agent over the live offers, from where the robot is now
   (`planning.plan_problem`), keeps what it learns from the inbox of this step;
4. merges the inbox, releases what it was outbid on, builds its bundle;
5. publishes its state when it changed, and every `HEARTBEAT_S` anyway while there are live
   offers or it holds bids (the liveness others judge it by, and what a lost datagram
   carried); an agent whose bids are held is expected to keep sending;
6. when idle, claims the task at the head of its path if it wins it and its view has not
   changed for `STABLE_S`; the user grants each offer to one claim, and the grant starts the
   task (`on_start`); the executor reports progress every renewal period and the end, and
   hears the user repeat its grant every renewal period.

With `refine` (`murdoch-robot --refine`), step 6 waits for the improvement phase of
`consensus_refine` over the settled snapshot, and the robot claims the head of its path in
the refined plan instead (as without `refine` when the phase is given up).

Under CBGA an offer may need several robots at once (a group offer, `group_offers`): the
robot bids on it when it can fill one of its seats, claims it (`SeatClaim`: the seats it can
fill, where it stands) when its view holds the full group with itself in it, and on its
`SeatGrant` runs that seat's task with that seat's parameters. Offers are checked when heard
(`group_offers.offer_problem`): a malformed one, or a group offer under CBBA, is refused,
counted (`counters["refused"]`) and logged, never planned over.

A task the user withdraws while this robot executes it (revoked after a silence, cancelled)
is stopped (`on_stop`), and so is one whose grant has not been repeated for the abandon
time (the user may have revoked it in a message this robot missed). Robots under consensus
offer no sub-tasks.
"""

from __future__ import annotations

import logging

from murdoch.allocators.base import Assignment, RobotHooks
from murdoch.allocators.consensus_refine import MAX_OFFERS, RefinePhase, Stance, check_refine
from murdoch.allocators.consensus_state import local_message, state_chunks
from murdoch.allocators.group_offers import (
    fillable,
    is_group,
    offer_problem,
    required,
    seat_place,
    seats,
)
from murdoch.allocators.planning import Profile, plan_profile, team_problem
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
    TeamRefine,
)
from murdoch.consensus.async_runner import ConsensusChunk
from murdoch.consensus.cbba import CbbaAgent
from murdoch.consensus.cbga import CbgaAgent
from murdoch.execution.executor import Execution
from murdoch.execution.task_robot import ABANDON_AFTER_S, PROGRESS_S, TaskRobot
from murdoch.transport import Clock, Transport

log = logging.getLogger(__name__)

HEARTBEAT_S = 2.0
SILENT_S = 6.0
"""Three heartbeats missed: the agent is taken for dead."""
STABLE_S = 1.0
CLAIM_RETRY_S = 3.0
ENDED_KEPT = 16

Agent = CbbaAgent | CbgaAgent


class ConsensusRobot(TaskRobot[TaskOffer]):
    """A robot's `TeamMember` for CBBA (`algorithm="cbba"`) or CBGA (`"cbga"`); `refine`
    adds the improvement phase (`consensus_refine`)."""

    def __init__(self, transport: Transport, clock: Clock, hooks: RobotHooks,
                 algorithm: str, refine: bool = False) -> None:
        if algorithm not in ("cbba", "cbga"):
            raise ValueError(f"unknown consensus algorithm {algorithm!r}")
        if hooks.agent_id not in hooks.team:
            raise ValueError(f"{hooks.agent_id!r} is not in the team {list(hooks.team)}")
        self.algorithm = algorithm
        self.refine = refine
        self.phase: RefinePhase | None = None
        self._phase_epoch = -1.0
        self._refine_inbox: list[TeamRefine] = []
        self._profile: Profile | None = None
        self.index = hooks.team.index(hooks.agent_id)
        self.offers: dict[int, TaskOffer] = {}
        self.withdrawn: set[int] = set()
        self.order: list[int] = []
        self.agent: Agent | None = None
        self.heard: dict[int, float] = {}
        self.silent: set[int] = set()
        self._inbox: list[ConsensusChunk] = []
        self._replan = True
        self._seat = 0
        self._claim: tuple[int, float] | None = None
        self._claimed: TaskOffer | None = None
        self._last_sent: tuple[object, float] | None = None
        self._state: object = None
        self._stable_since = 0.0
        self.counters = {"claims": 0, "grants": 0, "replans": 0, "silent": 0, "refused": 0}
        if refine:
            self.counters.update(phases=0, refined=0, phases_given_up=0, refine_refused=0)
        super().__init__(transport, clock, hooks, {TEAM_SUBJECT, STATE_SUBJECT}, ENDED_KEPT)

    @property
    def _who(self) -> str:
        return f"{self.algorithm}: a robot"

    def _subjects_changed(self) -> None:
        self._replan = True

    def _freed(self) -> None:
        self._replan = True

    def _advance(self, now: float) -> None:
        self._notice_silence(now)
        if self._replan:
            self._rebuild(now)
        self._consensus(now)
        if self.refine:
            self._refine(now)
        self._maybe_claim(now)
        self._keep(now)

    # -- internals
    def _handle(self, msg: object, now: float) -> None:
        if isinstance(msg, ConsensusChunk):
            if msg.session == SESSION and msg.sender != self.index and \
                    0 <= msg.sender < len(self.hooks.team):
                self.heard[msg.sender] = now
                if msg.sender in self.silent:
                    self.silent.discard(msg.sender)
                    self._replan = True
                self._inbox.append(msg)
        elif isinstance(msg, TeamRefine):
            if self.refine and msg.sender != self.index:
                why = check_refine(msg, len(self.hooks.team))
                if why is None:
                    self.heard[msg.sender] = now
                    self._refine_inbox.append(msg)
                else:
                    self.counters["refine_refused"] += 1
                    n = self.counters["refine_refused"]
                    if n == 1 or n % 100 == 0:
                        log.warning("%s: refused %d refine message(s), last from agent %s: %s",
                                    self.hooks.agent_id, n, msg.sender, why)
        elif isinstance(msg, TaskOffer):
            if msg.offer not in self.offers and msg.offer not in self.withdrawn:
                why = offer_problem(msg, team_size=len(self.hooks.team),
                                    groups=self.algorithm == "cbga")
                if why is None:
                    self.offers[msg.offer] = msg
                    self._replan = True
                else:
                    self.counters["refused"] += 1
                    n = self.counters["refused"]
                    if n == 1 or n % 100 == 0:
                        log.warning("%s: refused %d offer(s), last %s (offer %d): %s",
                                    self.hooks.agent_id, n, msg.task_id, msg.offer, why)
        elif isinstance(msg, TaskGrant):
            self._withdraw(msg.offer)
            ex = self._executing
            if ex is not None and ex.offer == msg.offer and msg.robot == self.hooks.agent_id:
                self._execution.renewed(now)  # the user repeats its grant: a renewal
            elif msg.offer in self._ended and msg.robot == self.hooks.agent_id:
                self._publish(STATE_SUBJECT, self._ended.get(msg.offer))  # the report was lost
            elif msg.robot == self.hooks.agent_id:
                self._granted(msg, now)
            elif self._claim is not None and self._claim[0] == msg.offer and \
                    not isinstance(msg, SeatGrant):
                self._claim = None  # (a group's other seats: this robot's may follow)
        elif isinstance(msg, TaskWithdraw):
            self._withdraw(msg.offer)
            ex = self._executing
            if ex is not None and ex.offer == msg.offer:
                self._stop(ex, now, msg.reason)
            if self._claim is not None and self._claim[0] == msg.offer:
                self._claim = None

    def _withdraw(self, offer: int) -> None:
        if offer not in self.withdrawn:
            self.withdrawn.add(offer)
            self._replan = True
        self.offers.pop(offer, None)

    def _granted(self, grant: TaskGrant, now: float) -> None:
        claim, self._claim = self._claim, None
        offer = None
        if claim is not None and claim[0] == grant.offer:
            offer = self._claimed
        seat = grant.seat if isinstance(grant, SeatGrant) else 0
        why = ""
        if offer is None or self._executing is not None:
            why = "granted a task it no longer claims"
        elif not self._subjects:
            why = "left the team (charging)"
        elif isinstance(grant, SeatGrant) != is_group(offer) or seat not in fillable(
                offer, frozenset(self._subjects), self.hooks.knows):
            why = f"granted seat {seat}, which it cannot fill"
        if offer is None or why:
            self._publish(STATE_SUBJECT, TaskReport(grant.task_id, grant.offer,
                                                    self.hooks.agent_id, "abandoned", 0.0, why))
            return
        self._executing = offer
        self._seat = seat
        self._execution = Execution.start(now, ABANDON_AFTER_S, PROGRESS_S)
        self.counters["grants"] += 1
        place = seats(offer)[seat]
        self._emit(now, "start", offer.task_id, offer=offer.offer,
                   **({"seat": seat} if is_group(offer) else {}))
        self.hooks.on_start(Assignment(offer.task_id, place.kind, place.params))

    def _notice_silence(self, now: float) -> None:
        holders: set[int] | None = None
        for k, t in self.heard.items():
            if k in self.silent or now - t <= SILENT_S:
                continue
            if holders is None:  # (rarely: only when someone is overdue)
                holders = set().union(*self.agent.winners_view()) if self.agent else set()
            if k in holders:  # it holds bids, so it would be sending its state
                self.silent.add(k)
                self.counters["silent"] += 1
                if self.agent is not None:
                    self.agent.forget_agent(k)

    def _rebuild(self, now: float) -> None:
        self._replan = False
        self.counters["replans"] += 1
        self.order = sorted(self.offers)
        offers = [self.offers[o] for o in self.order]
        ex = self._executing
        if ex is not None:
            left = max(0.0, ex.duration_s - (now - self._execution.started_at))
            position = (seat_place(ex, seats(ex)[self._seat]) if self.hooks.speed_mps > 0
                        else self.hooks.position())
            available = now + left
        else:
            position, available = self.hooks.position(), now
        names = {s.kind for o in offers for s in seats(o)}
        profile = plan_profile(
            offers, subjects=frozenset(self._subjects),
            can_do={n: self.hooks.knows(n) for n in names}, position=position,
            speed_mps=self.hooks.speed_mps, available_at=available)
        self._profile = profile
        problem = team_problem(self.hooks.team, {self.index: profile}, offers)
        agent: Agent = (CbbaAgent(problem, self.index) if self.algorithm == "cbba"
                        else CbgaAgent(problem, self.index))
        for k in self.silent:
            agent.forget_agent(k)
        self.agent = agent
        self._state = None

    def _consensus(self, now: float) -> None:
        a = self.agent
        assert a is not None
        inbox, self._inbox = self._inbox, []
        groups: dict[tuple[int, float], list[ConsensusChunk]] = {}
        for c in inbox:
            groups.setdefault((c.sender, c.time), []).append(c)
        for chunks in groups.values():
            last = None
            for c in chunks:
                msg, tasks = local_message(c, a.kind, self.order, self.silent)
                a.receive(msg, now, tasks, merge=False)
                last = msg
            if last is not None:
                a.merge_stamps(last, now)
        a.release_outbid()
        if isinstance(a, CbgaAgent):
            a.refresh_times()
        a.build_bundle(now)
        state = a.state_key()
        if state != self._state:
            self._state = state
            self._stable_since = now
        sent = (tuple(self.order), a.sent_data())
        last_sent = self._last_sent
        beat = bool(a.bundle or self.offers) and (last_sent is None
                                                  or now - last_sent[1] >= HEARTBEAT_S)
        if last_sent is None or last_sent[0] != sent or beat:
            self._last_sent = (sent, now)
            for chunk in state_chunks(a.message(now), self.order):
                self._publish(STATE_SUBJECT, chunk)

    def _members(self, now: float) -> tuple[int, ...]:
        """The agents a phase opened now takes part with: this one and those heard within
        the silence limit and not found silent."""
        heard = {k for k, t in self.heard.items()
                 if k not in self.silent and now - t <= SILENT_S}
        return tuple(sorted(heard | {self.index}))

    def _refine(self, now: float) -> None:
        """Open, restart, step or drop the improvement phase; send its state."""
        inbox, self._refine_inbox = self._refine_inbox, []
        a, profile = self.agent, self._profile
        settled = (a is not None and profile is not None and bool(self.offers)
                   and len(self.order) <= MAX_OFFERS and now - self._stable_since >= STABLE_S
                   and any(a.winners_view())  # (nothing won: nothing to exchange)
                   and not any(is_group(o) for o in self.offers.values()))
        members = self._members(now)
        phase = self.phase
        if phase is not None and (not settled or self._phase_epoch != self._stable_since
                                  or phase.snapshot != (tuple(self.order), members)):
            phase = self.phase = None  # the plan it refined has changed
        if phase is None and settled:
            assert a is not None and profile is not None
            phase = self._open_phase(now, members, now)
        if phase is None:
            return
        for msg in inbox:
            phase.receive(msg)
        if phase.restart:
            phase = self._open_phase(now, members, phase.opened_at)
            for msg in inbox:
                phase.receive(msg)
        was_pending = phase.pending
        phase.advance(now)
        if was_pending and phase.done:
            self.counters["refined"] += 1
            self._emit(now, "refined", "", moves=phase.agent.moves if phase.agent else 0,
                       path=list(phase.path()))
        elif was_pending and phase.failed is not None:
            self.counters["phases_given_up"] += 1
            self._emit(now, "refine_given_up", "", reason=phase.failed)
        if phase.pending or (phase.done and phase.lagging):
            for msg in phase.messages():
                self._publish(STATE_SUBJECT, msg)
        phase.lagging = False
        self.counters["refine_refused"] += phase.refused
        phase.refused = 0

    def _open_phase(self, now: float, members: tuple[int, ...],
                    opened_at: float) -> RefinePhase:
        a, profile = self.agent, self._profile
        assert a is not None and profile is not None
        path = tuple(self.order[j] for j in a.path)
        offers = [self.offers[o] for o in self.order]
        self.phase = RefinePhase(self.index, offers, members, Stance(profile, path), opened_at)
        self._phase_epoch = self._stable_since
        self.counters["phases"] += 1
        return self.phase

    def _maybe_claim(self, now: float) -> None:
        a = self.agent
        if a is None or self._executing is not None or not self._subjects:
            return
        if self._claim is not None and now - self._claim[1] < CLAIM_RETRY_S:
            return
        if now - self._stable_since < STABLE_S:
            return
        phase = self.phase if self.refine else None
        if phase is not None and phase.pending:
            return  # the phase decides who claims what
        if phase is not None and phase.done:
            path = phase.path()
            if path and path[0] in self.offers:
                self._send_claim(now, self.offers[path[0]], phase.path_value())
            return
        if not a.path:
            return
        j = a.path[0]
        winners = a.winners_view()[j]
        offer = self.offers[self.order[j]]
        if self.index not in winners or len(winners) < required(offer):
            return  # (a group offer: claimed once the group is full in this view)
        bid = a.y[j] if isinstance(a, CbbaAgent) else a.x[j][self.index]
        self._send_claim(now, offer, bid)

    def _send_claim(self, now: float, offer: TaskOffer, bid: float) -> None:
        self._claim = (offer.offer, now)
        self._claimed = offer
        self.counters["claims"] += 1
        self._emit(now, "claim", offer.task_id, offer=offer.offer, bid=bid)
        if is_group(offer):
            x, y = self.hooks.position()
            claim: TaskClaim = SeatClaim(
                offer.task_id, offer.offer, self.hooks.agent_id, float(bid),
                fillable(offer, frozenset(self._subjects), self.hooks.knows), float(x), float(y))
        else:
            claim = TaskClaim(offer.task_id, offer.offer, self.hooks.agent_id, float(bid))
        self._publish(STATE_SUBJECT, claim)
