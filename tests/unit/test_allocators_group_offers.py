"""Group offers: CBGA robots take a task that needs two robots at once whole, on the
in-memory bus (seats, claims, grants, a lost member, a group that cannot be formed, refused
offers), and the pure rules of `group_offers`."""

from __future__ import annotations

import random
from typing import Any

import pytest
from sibling import load_sibling

from murdoch.allocators import allocator
from murdoch.allocators.group_offers import (
    MAX_SEATS,
    fillable,
    offer_problem,
    required,
    seat_place,
    seat_plan,
    seats,
)
from murdoch.allocators.planning import capable_offers, team_problem
from murdoch.allocators.team_messages import (
    TEAM_CODEC,
    TEAM_SUBJECT,
    SeatClaim,
    TaskOffer,
)
from murdoch.auction.timing import USER_TASK

_T = load_sibling(__file__, "test_allocators_consensus.py")
TRACK = frozenset({"camera", "mobile"})


def group_params(spots: list[tuple[float, float]], duration_s: float = 6.0,
                 equipment: tuple[str, ...] = ("camera", "mobile")) -> dict[str, Any]:
    cx, cy = sum(x for x, _ in spots) / len(spots), sum(y for _, y in spots) / len(spots)
    return {"required": len(spots), "duration_s": duration_s, "colour": "#ff0000",
            "object_x": cx, "object_y": cy, "x": cx, "y": cy,
            "members": [{"kind": "watch-side", "equipment": list(equipment),
                         "params": {"x": x, "y": y, "duration_s": duration_s, "side": k}}
                        for k, (x, y) in enumerate(spots)]}


def group_offer(spots: list[tuple[float, float]], offer: int = 0, **kw: Any) -> TaskOffer:
    params = group_params(spots, **kw)
    return TaskOffer("g", offer, "watch-pair", ("camera", "mobile"), params,
                     float(params["duration_s"]), params["object_x"], params["object_y"], 0.0)


def decoded(offer: TaskOffer) -> TaskOffer:
    """The offer as a robot hears it (read-only mappings, tuples)."""
    data = TEAM_CODEC.encode_frame("user", 0, frozenset({TEAM_SUBJECT}), offer)
    return TEAM_CODEC.message_of(TEAM_CODEC.parse_frame(data))


# -- the pure rules ---------------------------------------------------------------------------


def test_a_group_offer_has_a_seat_per_member_and_a_plain_one_has_one() -> None:
    g = decoded(group_offer([(1.0, 0.0), (-1.0, 0.0)]))
    assert required(g) == 2
    assert [s.kind for s in seats(g)] == ["watch-side", "watch-side"]
    assert seats(g)[1].params["x"] == -1.0 and seats(g)[0].equipment == TRACK
    plain = TaskOffer("t", 1, "track", ("camera",), {"x": 1}, 3.0, 0.0, 0.0, 0.0)
    assert required(plain) == 1 and [s.kind for s in seats(plain)] == ["track"]
    assert fillable(g, TRACK, lambda k: True) == (0, 1)
    assert fillable(g, frozenset({"mobile"}), lambda k: True) == ()
    assert fillable(g, TRACK, lambda k: k != "watch-side") == ()


def test_the_problem_asks_for_the_group_and_checks_equipment_per_seat() -> None:
    g = decoded(group_offer([(1.0, 0.0), (-1.0, 0.0)]))
    plain = TaskOffer("t", 1, "track", ("camera", "mobile"), {}, 3.0, 0.0, 0.0, 0.0)
    assert capable_offers([g, plain], TRACK, {"watch-side": True, "track": True}) == {0, 1}
    assert capable_offers([g, plain], frozenset({"camera"}), {"watch-side": True}) == set()
    problem = team_problem(("a", "b", "c"), {}, [g, plain])
    assert list(problem.lists.required) == [2, 1]
    assert problem.task_equipment == (frozenset(), TRACK)  # (seats check it per robot)


@pytest.mark.parametrize("change, why", [
    (lambda p: p.update(members=p["members"][:1], required=1), "expected 2 to"),
    (lambda p: p.update(members=p["members"] * 3, required=6), "expected 2 to"),
    (lambda p: p.update(required=3), "required 3 but 2 members"),
    (lambda p: p["members"][0].update(kind=7), "member 0: expected a task kind"),
    (lambda p: p["members"][1].update(equipment="camera"), "member 1: expected equipment"),
    (lambda p: p["members"][1].update(params=[1]), "member 1: expected params"),
    (lambda p: p.update(members="two"), "expected 2 to"),
])
def test_a_malformed_group_offer_is_named(change: Any, why: str) -> None:
    params = group_params([(1.0, 0.0), (-1.0, 0.0)])
    change(params)
    offer = decoded(TaskOffer("g", 0, "watch-pair", (), params, 5.0, 0.0, 0.0, 0.0))
    problem = offer_problem(offer, team_size=7, groups=True)
    assert problem is not None and why in problem


def test_offers_are_checked_for_what_the_team_can_take() -> None:
    g = decoded(group_offer([(1.0, 0.0), (-1.0, 0.0)]))
    assert offer_problem(g, team_size=7, groups=True) is None
    assert "single robots" in str(offer_problem(g, team_size=7, groups=False))
    assert "the team has 1" in str(offer_problem(g, team_size=1, groups=True))
    bad = TaskOffer("t", 3, "track", (), {}, -1.0, 0.0, 0.0, 0.0)
    assert "negative" in str(offer_problem(bad, team_size=7, groups=False))
    assert MAX_SEATS >= 2


def claim(robot: str, x: float, y: float, seats_: tuple[int, ...] = (0, 1),
          bid: float = 50.0) -> SeatClaim:
    return SeatClaim("g", 0, robot, bid, seats_, x, y)


def test_seats_go_to_the_nearer_claimants() -> None:
    g = decoded(group_offer([(5.0, 0.0), (-5.0, 0.0)]))
    assert seat_plan(g, [claim("a", -4.0, 0.0), claim("b", 4.0, 0.0)]) == {"b": 0, "a": 1}
    assert seat_plan(g, [claim("a", 4.0, 0.0), claim("b", -4.0, 0.0)]) == {"a": 0, "b": 1}
    # a robot gets only a seat it can fill, even when it stands nearer the other
    assert seat_plan(g, [claim("a", 5.0, 0.0, (1,)), claim("b", -5.0, 0.0)]) == \
        {"b": 0, "a": 1}


def test_no_seats_are_handed_out_until_every_seat_can_be_filled() -> None:
    g = decoded(group_offer([(5.0, 0.0), (-5.0, 0.0)]))
    assert seat_plan(g, [claim("a", 0.0, 0.0)]) is None
    assert seat_plan(g, [claim("a", 0.0, 0.0, (0,)), claim("b", 0.0, 0.0, (0,))]) is None
    # among many claimants, the two nearer ones
    many = [claim(f"r{k}", 5.0 + k, 0.0) for k in range(6)] + [claim("w", -5.0, 0.0)]
    assert seat_plan(g, many) == {"r0": 0, "w": 1}


# -- on the bus -------------------------------------------------------------------------------


class GroupTeam(_T.Team):  # type: ignore[name-defined,misc]
    def offer_group(self, spots: list[tuple[float, float]], duration_s: float = 6.0,
                    patience_s: float = 60.0) -> str:
        params = group_params(spots, duration_s)
        spec = USER_TASK.task("watch-pair", TRACK, params, duration_s=duration_s,
                              timeout_s=duration_s + 600.0)
        return str(self.user.announce(spec, patience_s=patience_s))

    def groups_at_once(self) -> dict[str, int]:
        """Per task, the most robots that executed it at once."""
        running: dict[str, set[str]] = {}
        most: dict[str, int] = {}
        for _, robot, task, what in self.log:
            if what == "start":
                running.setdefault(task, set()).add(robot)
            else:
                running.get(task, set()).discard(robot)
            most[task] = max(most.get(task, 0), len(running.get(task, ())))
        return most


def test_the_group_is_formed_whole_and_each_robot_runs_its_seat() -> None:
    team = GroupTeam("cbga", seed=2)
    task = team.offer_group([(1.0, 0.0), (6.0, 0.0)])
    team.run(60.0)
    assert team.outcomes()[task] == ["completed"]
    starts = [(r, t) for _, r, t, what in team.log if what == "start" and t == task]
    assert len(starts) == 2 and len({r for r, _ in starts}) == 2
    awards = [e for e in team.events if e.kind == "award" and e.task_id == task]
    assert sorted(e.detail["seat"] for e in awards) == [0, 1]
    by_seat = {e.detail["seat"]: e.detail["winner"] for e in awards}
    assert by_seat == {0: "r0", 1: "r1"}  # each the robot nearer its spot
    assert team.groups_at_once()[task] == 2


@pytest.mark.parametrize("loss", [0.0, 0.2])
def test_groups_and_single_tasks_arriving_over_time_end_once_each(loss: float) -> None:
    team = GroupTeam("cbga", loss=loss, seed=7)
    rng = random.Random(11)
    groups, singles = [], []
    for k in range(6):
        if k % 2:
            groups.append(team.offer_group([(rng.uniform(0, 5), rng.uniform(0, 5)),
                                            (rng.uniform(0, 5), rng.uniform(0, 5))], 4.0))
        else:
            singles.append(team.offer("track", rng.uniform(0, 5), rng.uniform(0, 5), 4.0))
        team.run(rng.uniform(0.5, 3.0))
    team.run(200.0)
    outcomes = team.outcomes()
    assert {t: outcomes[t] for t in groups + singles} == \
        {t: ["completed"] for t in groups + singles}
    most = team.groups_at_once()
    assert all(most[t] == 2 for t in groups) and all(most[t] == 1 for t in singles)
    for task in groups:
        done = {r for _, r, t, what in team.log if what == "done" and t == task}
        assert len(done) == 2


def test_a_lost_member_sends_the_group_back_whole() -> None:
    team = GroupTeam("cbga", seed=4)
    task = team.offer_group([(1.0, 0.0), (4.0, 5.0)], duration_s=40.0)
    team.run(10.0)
    holders = sorted(r for r, (t, _) in team.running.items() if t == task)
    assert len(holders) == 2
    team.kill(holders[0])
    team.run(150.0)
    assert team.outcomes()[task] == ["completed"]
    kinds = [e.kind for e in team.events if e.task_id == task]
    assert "reallocation" in kinds
    realloc = next(e for e in team.events if e.kind == "reallocation" and e.task_id == task)
    assert realloc.detail["winner"] == holders[0]
    stopped = [r for _, r, t, what in team.log if what == "stop" and t == task]
    assert holders[1] in stopped  # the survivor was stopped with the withdrawal
    done = {r for _, r, t, what in team.log if what == "done" and t == task}
    assert len(done) == 2 and holders[0] not in done
    assert max(team.groups_at_once().values()) == 2


def test_a_group_no_two_robots_can_form_ends_unachievable() -> None:
    team = GroupTeam("cbga", seed=5)
    for name in ("r1", "r2", "r3"):
        team.kill(name)
        team.start(name, frozenset({"mobile"}))  # no camera: no seat they can fill
    task = team.offer_group([(1.0, 0.0), (4.0, 0.0)], patience_s=40.0)
    team.run(200.0)
    assert team.outcomes()[task] == ["unachievable"]
    assert not [1 for _, _, t, what in team.log if what == "start" and t == task]


def test_group_offers_a_team_cannot_take_are_refused_and_counted() -> None:
    team = GroupTeam("cbba", seed=6)
    forged = team.bus.endpoint("intruder", TEAM_CODEC)
    forged.publish({TEAM_SUBJECT}, group_offer([(1.0, 0.0), (2.0, 0.0)], offer=900))
    params = group_params([(1.0, 0.0)] * 2)
    params["members"] = params["members"] * 3  # six robots: more than a group may need
    params["required"] = 6
    forged.publish({TEAM_SUBJECT}, TaskOffer("h", 901, "watch-pair", (), params, 5.0,
                                             0.0, 0.0, 0.0))
    task = team.offer("track", 2.0, 2.0, duration_s=3.0)
    team.run(30.0)
    assert team.outcomes()[task] == ["completed"]  # the others' work goes on
    assert all(m.counters["refused"] == 2 for m in team.members.values())
    assert all(not m.offers.keys() & {900, 901} for m in team.members.values())
    cbga = GroupTeam("cbga", seed=6)
    forged = cbga.bus.endpoint("intruder", TEAM_CODEC)
    forged.publish({TEAM_SUBJECT}, TaskOffer("h", 901, "watch-pair", (), params, 5.0,
                                             0.0, 0.0, 0.0))
    cbga.run(2.0)
    assert all(m.counters["refused"] == 1 for m in cbga.members.values())


def test_only_cbga_takes_group_tasks_whole() -> None:
    assert allocator("cbga").group_tasks and allocator("cbga", refine=True).group_tasks
    assert not allocator("cbba").group_tasks and not allocator("murdoch").group_tasks


def test_a_seat_is_done_at_its_spot_and_a_plain_offer_where_the_user_put_it() -> None:
    g = decoded(group_offer([(1.0, 0.0), (-1.0, 2.0)]))
    assert [seat_place(g, s) for s in seats(g)] == [(1.0, 0.0), (-1.0, 2.0)]
    plain = TaskOffer("t", 1, "track", (), {"x": 9.0, "y": 9.0}, 3.0, 2.0, 3.0, 0.0)
    assert seat_place(plain, seats(plain)[0]) == (2.0, 3.0)
