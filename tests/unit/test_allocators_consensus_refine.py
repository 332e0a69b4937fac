"""The robots' `--refine` phase (`murdoch.allocators.consensus_refine`): the phase alone on a
hand-made snapshot, then CBBA and CBGA teams on the in-memory bus while tasks arrive, a
robot leaves to charge and a robot dies. Every plan a phase agrees on is checked: the same
on every robot that took the same snapshot, conflict-free and feasible."""

from __future__ import annotations

import math
import random
from collections import defaultdict

import pytest
from sibling import load_sibling

from murdoch.allocators import REFINABLE, allocator
from murdoch.allocators.consensus_refine import (
    MAX_OFFERS,
    REFINE_WAIT_S,
    RefinePhase,
    Stance,
    check_refine,
)
from murdoch.allocators.consensus_robot import ConsensusRobot
from murdoch.allocators.planning import Profile, team_problem
from murdoch.allocators.team_messages import TEAM_CODEC, TaskOffer, TeamRefine
from murdoch.consensus.refine import PlanScorer

_T = load_sibling(__file__, "test_allocators_consensus.py")
DT = _T.DT
ALGORITHMS = ["cbba", "cbga"]
TRACK = ("camera", "mobile")


def _offer(n: int, x: float) -> TaskOffer:
    return TaskOffer(f"t{n}", n, "track", TRACK, {}, 5.0, x, 0.0, 0.0)


def _profile(x: float, capable: set[int]) -> Profile:
    return Profile((x, 0.0), 0.5, 0.0, frozenset(capable), frozenset(TRACK))


def _exchange(phases: list[RefinePhase], rounds: int = 20) -> None:
    now = 0.0
    for _ in range(rounds):
        sent = [m for p in phases if p.pending or (p.done and p.lagging) for m in p.messages()]
        for p in phases:
            p.lagging = False
            for m in sent:
                p.receive(m)
            p.advance(now)
        now += DT


def test_a_phase_hands_a_task_to_the_idle_robot_and_every_member_agrees() -> None:
    offers = [_offer(3, 1.0), _offer(7, 9.0)]
    # robot 0 at x=0 holds both tasks (as a consensus that settled badly could); robot 2 is
    # idle next to the far one; robot 1 of the team is dead and takes no part
    stances = {0: Stance(_profile(0.0, {3, 7}), (3, 7)), 2: Stance(_profile(10.0, {3, 7}), ())}
    phases = [RefinePhase(i, offers, (0, 2), stances[i], 0.0) for i in (0, 2)]
    _exchange(phases)
    assert all(p.done for p in phases)
    assert [p.path() for p in phases] == [(3,), (7,)]
    plans = {p.agent.plan for p in phases if p.agent is not None}
    assert len(plans) == 1
    problem = team_problem(["0", "2"], {0: stances[0].profile, 1: stances[2].profile}, offers)
    scorer = PlanScorer(problem)
    (plan,) = plans
    assert scorer.score(plan) > scorer.score(((0, 1), ()))


def test_conflicting_paths_give_the_phase_up_and_silence_times_it_out() -> None:
    offers = [_offer(1, 1.0)]
    both = {i: Stance(_profile(float(i), {1}), (1,)) for i in (0, 1)}
    phases = [RefinePhase(i, offers, (0, 1), both[i], 0.0) for i in (0, 1)]
    _exchange(phases, rounds=2)
    assert all(p.failed == "the members' paths conflict" for p in phases)
    alone = RefinePhase(0, offers, (0, 1), Stance(_profile(0.0, {1}), (1,)), 0.0)
    alone.advance(REFINE_WAIT_S / 2)
    assert alone.pending
    alone.advance(REFINE_WAIT_S + DT)  # member 1 never answers (it died)
    assert alone.failed is not None and not alone.pending


def test_a_member_that_replans_restarts_the_phase() -> None:
    offers = [_offer(1, 1.0)]
    phase = RefinePhase(0, offers, (0, 1), Stance(_profile(0.0, {1}), (1,)), 0.0)
    other = RefinePhase(1, offers, (0, 1), Stance(_profile(5.0, {1}), ()), 0.0)
    for m in other.messages():
        phase.receive(m)
    assert not phase.restart
    moved = RefinePhase(1, offers, (0, 1), Stance(_profile(4.0, {1}), ()), 0.0)
    for m in moved.messages():
        phase.receive(m)
    assert phase.restart


def _message(**change: object) -> TeamRefine:
    base: dict[str, object] = dict(
        sender=1, offers=(2, 5), members=(0, 1), x=0.0, y=0.0, speed_mps=0.5,
        available_at=0.0, capable=(2,), subjects=TRACK, path=(2,), step=0,
        entries=((1, 0, 0.0, (0,)),), previous_step=-1, previous=())
    base.update(change)
    return TeamRefine(**base)  # type: ignore[arg-type]


@pytest.mark.parametrize(("change", "why"), [
    ({"members": (0, 9)}, "outside the team"),
    ({"sender": 0, "members": (-1, 0)}, "outside the team"),
    ({"sender": 2, "members": (0, 1)}, "sender outside"),
    ({"x": math.inf}, "not finite"),
    ({"speed_mps": -1.0}, "not finite"),
    ({"path": (2, 2)}, "outside the snapshot"),
    ({"capable": (4,)}, "outside the snapshot"),
    ({"offers": (5, 2)}, "not ascending"),
    ({"offers": tuple(range(MAX_OFFERS + 1))}, "too many"),
])
def test_malformed_refine_messages_are_refused(change: dict[str, object], why: str) -> None:
    assert check_refine(_message(), team_size=3) is None
    reason = check_refine(_message(**change), team_size=3)
    assert reason is not None and why in reason


def test_a_malformed_entry_is_dropped_and_counted() -> None:
    offers = [_offer(2, 1.0), _offer(5, 2.0)]
    phase = RefinePhase(0, offers, (0, 1), Stance(_profile(0.0, {2, 5}), ()), 0.0)
    phase.receive(_message())
    phase.advance(0.0)
    assert phase.agent is not None
    phase.receive(_message(step=1, entries=((1, 1, math.nan, (0, 1, 0)),)))
    assert phase.refused == 1


def test_the_largest_refine_message_fits_a_datagram() -> None:
    offers = [_offer(1000 + n, float(n)) for n in range(MAX_OFFERS)]
    ids = tuple(o.offer for o in offers)
    members = tuple(range(12))
    stances = {i: Stance(Profile((123.456789 + i, -98.7654321), 0.5, 12345.678901,
                                 frozenset(ids), frozenset(TRACK)), ids[2 * i:2 * i + 2])
               for i in members}
    phases = [RefinePhase(i, offers, members, stances[i], 0.0) for i in members]
    for _ in range(3):
        sent = [m for p in phases for m in p.messages()]
        for m in sent:
            frame = TEAM_CODEC.encode_frame("robot-name", 123456, frozenset({"team.state"}), m)
            assert len(frame) <= 1400
        for p in phases:
            for m in sent:
                p.receive(m)
            p.advance(0.0)


def test_refine_is_for_the_consensus_allocators() -> None:
    assert REFINABLE == ("cbba", "cbga")
    assert allocator("cbba", refine=True).refine and not allocator("cbba").refine
    with pytest.raises(ValueError, match="--refine is for the consensus allocators"):
        allocator("murdoch", refine=True)


class RefinedTeam(_T.Team):  # type: ignore[name-defined,misc]
    """The test team with `--refine`, checking every agreed plan after each tick."""

    refine = True

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self.agreed: list[tuple[tuple[int, ...], tuple[int, ...]]] = []  # (members, plan)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT)):
            super().run(DT)
            self.check_plans()

    def check_plans(self) -> None:
        groups: dict[object, list[ConsensusRobot]] = defaultdict(list)
        for m in self.members.values():
            p = m.phase
            if p is not None and p.done:
                groups[(p.snapshot, tuple(sorted(p.stances.items())))].append(m)
        for robots in groups.values():
            phase = robots[0].phase
            assert phase is not None and phase.agent is not None
            plans = {r.phase.agent.plan for r in robots}  # type: ignore[union-attr]
            assert len(plans) == 1, "members of one snapshot hold different plans"
            (plan,) = plans
            held = [j for q in plan for j in q]
            assert len(held) == len(set(held)), "a task on two paths"
            assert PlanScorer(phase.agent.scorer.p).score(plan) > -math.inf, "infeasible"
            entry = (phase.members, tuple(phase.offers[j] for q in plan for j in q))
            if entry not in self.agreed:
                self.agreed.append(entry)


def _counters(team: RefinedTeam, key: str) -> int:
    return sum(m.counters[key] for m in team.members.values())


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("loss", [0.0, 0.2])
def test_refined_tasks_arriving_over_time_are_each_done_once(algorithm: str,
                                                            loss: float) -> None:
    team = RefinedTeam(algorithm, loss=loss, seed=3)
    ids = []
    rng = random.Random(5)
    for _ in range(8):
        ids.append(team.offer("track", rng.uniform(0, 5), rng.uniform(0, 5), duration_s=4.0))
        team.run(rng.uniform(0.5, 3.0))
    team.run(90.0)
    outcomes = team.outcomes()
    assert {t: outcomes[t] for t in ids} == {t: ["completed"] for t in ids}
    team.check_never_two_at_once()
    assert _counters(team, "refined") > 0 and team.agreed
    assert _counters(team, "refine_refused") == 0


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_refined_team_gives_a_charging_robots_tasks_away(algorithm: str) -> None:
    team = RefinedTeam(algorithm, robots={"a": (0.0, 0.0), "b": (30.0, 0.0)})
    tasks = {team.offer("track", 0.0, 1.0, duration_s=20.0),
             team.offer("track", 0.0, 2.0, duration_s=20.0)}
    team.run(3.0)
    busy = team.running["a"][0]
    (queued,) = tasks - {busy}
    team.members["a"].set_subjects(())  # charging after this task: it may take nothing more
    team.run(60.0)
    done = {t: r for _, r, t, what in team.log if what == "done"}
    assert done == {busy: "a", queued: "b"}
    team.check_never_two_at_once()


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_refined_team_carries_on_without_a_robot_that_went_silent(algorithm: str) -> None:
    team = RefinedTeam(algorithm, seed=2, robots={"a": (0.0, 0.0), "b": (40.0, 0.0),
                                                  "c": (20.0, 20.0)})
    first = {team.offer("track", 0.0, 1.0, duration_s=30.0),
             team.offer("track", 0.0, 2.0, duration_s=30.0)}
    team.run(4.0)
    assert "a" in team.running
    team.kill("a")  # silent from now on: its phases' entries never come
    team.agreed.clear()
    team.run(30.0)
    later = {team.offer("track", 39.0, 0.0, duration_s=3.0),
             team.offer("track", 20.0, 19.0, duration_s=3.0)}
    team.run(150.0)
    outcomes = team.outcomes()
    assert {t: outcomes[t] for t in first | later} == {t: ["completed"] for t in first | later}
    assert "a" not in {r for _, r, _, what in team.log if what == "done"}
    # after the silence, phases agree among the living only
    assert team.agreed and all(0 not in members for members, _ in team.agreed[-2:])
    team.check_never_two_at_once()


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_refine_off_leaves_the_plain_members_alone(algorithm: str) -> None:
    team = _T.Team(algorithm, seed=1)
    team.offer("track", 1.0, 1.0, duration_s=3.0)
    team.run(10.0)
    assert all(m.phase is None and "phases" not in m.counters for m in team.members.values())
