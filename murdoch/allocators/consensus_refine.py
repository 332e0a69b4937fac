"""A robot's `--refine` phase: the improvement phase of `murdoch.consensus.refine` on a
settled snapshot of the team's plan (pure).

On the robots, tasks arrive over time and robots come, go to charge and die, so there is no
single run to refine after. Each time a robot's consensus state has been settled for the
claim's wait (`consensus_robot.STABLE_S`) while offers are live, it opens a phase over a
*snapshot*: the live offers (ascending) and the agents taking part (itself and every agent
it has heard within the silence limit and not found silent, ascending). In lockstep every
robot hears the same datagrams, so the robots of the team take the same snapshot.

A robot's agent plans knowing only itself (`planning.plan_problem`), while the phase
evaluates everyone's paths. So each robot's phase message (`TeamRefine`) carries, beside the
phase's entries, how the robot plans (`planning.Profile`) and its consensus path. Once a
robot holds the profiles of every agent of the snapshot it builds the same problem as every
other (`planning.team_problem` over the members), the agreed plan from the paths (the
phase's step 0, taken from the profiles' paths, so it costs no round of its own) and runs
`refine.RefineAgent` from there: proposals, the same selection everywhere, until a step
without proposals or `REFINE_STEPS`. Messages are whole states, re-sent every step while
the phase runs (`async_refine.refine_chunks`: entries of the current step and the complete
step before, in one datagram while they fit), so lost or repeated datagrams cost steps,
not the phase. A robot that has finished sends its final state again only when it hears a
member that has not.

The phase is given up (`failed`, and the robot claims as without `--refine`) when the paths
conflict (the consensus had not settled everywhere), when it has not finished within
`REFINE_WAIT_S`, or when the snapshot is too large for a datagram (`MAX_OFFERS`). A member
whose profile changes restarts the phase (`restart`). Whatever the phases decide, the user's
grant still gives each offer to one claim: the phase can only change who claims what.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

from murdoch.allocators.planning import Profile, team_problem
from murdoch.allocators.team_messages import SESSION, TaskOffer, TeamRefine
from murdoch.consensus.async_refine import RefineChunk, receive_chunk, refine_chunks
from murdoch.consensus.refine import (
    PlanScorer,
    RefineAgent,
    RefineOptions,
    canonical_plan,
    make_refine_agent,
    seeded_rank,
)

REFINE_STEPS = 6
"""Proposal steps per phase at most (each one tick of the team's loop in lockstep)."""
REFINE_WAIT_S = 3.0
"""A phase not finished this long after it opened is given up (a member died or never
took the same snapshot): the robot claims as the plain algorithm does."""
MAX_OFFERS = 24
"""A snapshot of more offers is not refined (its messages would outgrow a datagram)."""
OPTIONS = RefineOptions(seed=0, max_steps=REFINE_STEPS, opening=False, budget=None)
"""The phase's options on the robots: no opening (a robot cannot know that every other
holds the same winners), no round budget (rounds are ticks here), the steps above."""

Snapshot = tuple[tuple[int, ...], tuple[int, ...]]
"""(offers, members): what a phase refines."""


@dataclass(frozen=True)
class Stance:
    """A member's part of the snapshot: how it plans and its consensus path (offers)."""

    profile: Profile
    path: tuple[int, ...]


def check_refine(msg: TeamRefine, team_size: int) -> str | None:
    """Why the message cannot be taken (None: it is well formed)."""
    offers, members = msg.offers, msg.members
    if list(offers) != sorted(set(offers)) or list(members) != sorted(set(members)):
        return "offers or members not ascending"
    if not members or members[0] < 0 or members[-1] >= team_size:
        return "a member outside the team"
    if msg.sender not in members:
        return "a sender outside its members"
    if len(offers) > MAX_OFFERS:
        return "too many offers"
    if not all(math.isfinite(v) for v in (msg.x, msg.y, msg.speed_mps, msg.available_at)) \
            or msg.speed_mps < 0:
        return "a profile value that is not finite"
    known = set(offers)
    if not set(msg.capable) <= known or not set(msg.path) <= known or \
            len(set(msg.path)) != len(msg.path):
        return "an offer outside the snapshot"
    return None


class RefinePhase:
    """One robot's phase over one snapshot."""

    def __init__(self, index: int, offers: Sequence[TaskOffer], members: Sequence[int],
                 stance: Stance, opened_at: float) -> None:
        self.index = index
        self.offer_list = tuple(offers)
        self.offers = tuple(o.offer for o in offers)
        self.members = tuple(members)
        self.local = self.members.index(index)
        self.stances: dict[int, Stance] = {index: stance}
        self.opened_at = opened_at
        self.agent: RefineAgent | None = None
        self._early: list[TeamRefine] = []
        self.failed: str | None = None
        self.refused = 0
        """Messages whose entries did not fit the snapshot (dropped)."""
        self.restart = False
        """A member's profile changed since this phase took it: open the phase again."""
        self.lagging = False
        """A member that has not finished was heard this step: send the final state."""

    @property
    def snapshot(self) -> Snapshot:
        return self.offers, self.members

    @property
    def stance(self) -> Stance:
        return self.stances[self.index]

    @property
    def done(self) -> bool:
        return self.failed is None and self.agent is not None and self.agent.done

    @property
    def pending(self) -> bool:
        return self.failed is None and not self.done

    def path(self) -> tuple[int, ...]:
        """This robot's path in the refined plan (offers); only when `done`."""
        assert self.agent is not None and self.agent.plan is not None
        return tuple(self.offers[j] for j in self.agent.plan[self.local])

    def path_value(self) -> float:
        """The refined path's value for this robot (what its claim bids)."""
        a = self.agent
        assert a is not None and a.plan is not None
        return a.scorer.path_value(self.local, a.plan[self.local])

    def receive(self, msg: TeamRefine) -> None:
        """Take a member's message of this snapshot (others are not for this phase)."""
        if (msg.offers, msg.members) != self.snapshot or msg.sender == self.index:
            return
        profile = Profile((msg.x, msg.y), msg.speed_mps, msg.available_at,
                          frozenset(msg.capable), frozenset(msg.subjects))
        stance = Stance(profile, msg.path)
        held = self.stances.get(msg.sender)
        if held is not None and held != stance:
            self.restart = True  # it re-planned: its path and profile are new
            return
        self.stances[msg.sender] = stance
        if msg.entries:
            self.lagging = True
        if self.agent is None:
            self._early.append(msg)
        elif self.failed is None:
            self._take(msg)

    def _take(self, msg: TeamRefine) -> None:
        assert self.agent is not None
        chunk = RefineChunk(SESSION, self.members.index(msg.sender), msg.step, msg.entries,
                            msg.previous_step, msg.previous)
        if not receive_chunk(self.agent, chunk):
            self.refused += 1

    def advance(self, now: float) -> None:
        """One step: start once every member's stance is in, act on a complete step."""
        if self.failed is not None:
            return
        if self.agent is None and len(self.stances) == len(self.members):
            self._start()
        if self.agent is not None and self.failed is None:
            self.agent.advance()
        if self.pending and now - self.opened_at > REFINE_WAIT_S:
            self.failed = f"not finished within {REFINE_WAIT_S:g} s"

    def _start(self) -> None:
        local = {o: j for j, o in enumerate(self.offers)}
        profiles = {n: self.stances[m].profile for n, m in enumerate(self.members)}
        problem = team_problem([str(m) for m in self.members], profiles, self.offer_list)
        scorer = PlanScorer(problem)
        paths = [tuple(local[o] for o in self.stances[m].path) for m in self.members]
        held = Counter(j for q in paths for j in q)
        if any(n > problem.required[j] for j, n in held.items()) or \
                scorer.score(canonical_plan(problem, paths)) == -math.inf:
            self.failed = "the members' paths conflict"
            return
        rank = seeded_rank(len(self.members), OPTIONS.seed)
        agent = make_refine_agent(scorer, self.local, rank, paths[self.local], OPTIONS)
        agent.receive((0, dict(enumerate(paths)), None))  # step 0: the paths are known
        self.agent = agent
        early, self._early = self._early, []
        for msg in early:
            self._take(msg)

    def messages(self) -> list[TeamRefine]:
        """What this robot sends this step (its whole phase state)."""
        st = self.stance
        pr = st.profile

        def wrap(step: int, entries: tuple[tuple[int, int, float, tuple[int, ...]], ...],
                 previous_step: int,
                 previous: tuple[tuple[int, int, float, tuple[int, ...]], ...]) -> TeamRefine:
            return TeamRefine(self.index, self.offers, self.members, pr.position[0],
                              pr.position[1], pr.speed_mps, pr.available_at,
                              tuple(sorted(pr.capable)), tuple(sorted(pr.subjects)), st.path,
                              step, entries, previous_step, previous)

        if self.agent is None or self.failed is not None:
            local = {o: j for j, o in enumerate(self.offers)}
            own = (self.local, 0, 0.0, tuple(local[o] for o in st.path))
            return [wrap(0, (own,), -1, ())]
        chunks = refine_chunks(self.agent, SESSION, self.local)
        current = [c for c in chunks if not c.previous]
        previous = [c for c in chunks if c.previous]
        out = []  # a part of the current step and one of the step before share a datagram
        for k in range(max(len(current), len(previous))):
            cur = current[k] if k < len(current) else None
            prev = previous[k] if k < len(previous) else None
            step = cur.step if cur is not None else self.agent.step
            prev_step = prev.previous_step if prev is not None else -1
            out.append(wrap(step, cur.entries if cur is not None else (), prev_step,
                            prev.previous if prev is not None else ()))
        return out
