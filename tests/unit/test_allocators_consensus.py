"""CBBA and CBGA team members on the in-memory bus: tasks and agents come and go, with loss."""

from __future__ import annotations

import random
from collections import defaultdict
from itertools import pairwise
from typing import Any

import pytest

from murdoch.allocators import ALLOCATORS, Assignment, RobotHooks, UserHooks, allocator
from murdoch.allocators.consensus_robot import ConsensusRobot
from murdoch.allocators.consensus_state import local_message, state_chunks
from murdoch.allocators.consensus_user import ConsensusUser
from murdoch.allocators.team_messages import TEAM_CODEC
from murdoch.auction.messages import AuctionEvent
from murdoch.auction.timing import USER_TASK
from murdoch.consensus.messages import KIND_CBBA, ConsensusMessage
from murdoch.memory_bus import MemoryBus, NetworkFaults
from murdoch.user_agent import RandomizedBackoff

DT = 0.1
TRACK = frozenset({"camera", "mobile"})


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class Team:
    """A user and robots that execute each task for its duration, then report it done."""

    refine = False  # the robots' improvement phase (test_allocators_consensus_refine.py)

    def __init__(self, algorithm: str, *, loss: float = 0.0, seed: int = 0,
                 robots: dict[str, tuple[float, float]] | None = None) -> None:
        self.algorithm = algorithm
        self.clock = Clock()
        self.bus = MemoryBus(self.clock, random.Random(seed), NetworkFaults(loss=loss))
        self.events: list[AuctionEvent] = []
        self.places = robots or {"r0": (0.0, 0.0), "r1": (5.0, 0.0), "r2": (0.0, 5.0),
                                 "r3": (5.0, 5.0)}
        self.names = tuple(self.places)
        self.user = ConsensusUser(
            self.bus.endpoint("user", TEAM_CODEC), self.clock,
            UserHooks("user", self.events.append,
                      RandomizedBackoff(random.Random(seed), base_s=5.0, cap_s=60.0),
                      locate=lambda name, p: (float(p["x"]), float(p["y"]))))
        self.members: dict[str, ConsensusRobot] = {}
        self.running: dict[str, tuple[str, float]] = {}
        self.log: list[tuple[float, str, str, str]] = []  # (t, robot, task, start|stop|done)
        self.subjects: dict[str, frozenset[str]] = {}
        for name in self.names:
            self.start(name)

    def start(self, name: str, subjects: frozenset[str] = TRACK) -> None:
        self.subjects[name] = subjects

        def on_start(a: Assignment) -> None:
            assert name not in self.running, f"{name} started {a.task_id} while busy"
            self.running[name] = (a.task_id, self.clock.now + float(a.params["duration_s"]))
            self.log.append((self.clock.now, name, a.task_id, "start"))

        def on_stop(a: Assignment, reason: str) -> None:
            if self.running.get(name, ("",))[0] == a.task_id:
                del self.running[name]
                self.log.append((self.clock.now, name, a.task_id, "stop"))

        hooks = RobotHooks(name, subjects, score=lambda n, p, t: 1.0, knows=lambda n: True,
                           on_start=on_start, on_stop=on_stop,
                           position=lambda: self.places[name], speed_mps=0.5, team=self.names)
        self.members[name] = ConsensusRobot(self.bus.endpoint(name, TEAM_CODEC), self.clock,
                                            hooks, self.algorithm, refine=self.refine)

    def kill(self, name: str) -> None:
        self.members.pop(name).close()
        self.bus.detach(name)
        if name in self.running:
            task_id, _ = self.running.pop(name)
            self.log.append((self.clock.now, name, task_id, "stop"))

    def offer(self, task: str, x: float, y: float, duration_s: float = 5.0,
              subjects: frozenset[str] = TRACK) -> str:
        spec = USER_TASK.task(task, subjects, {"x": x, "y": y, "duration_s": duration_s},
                              duration_s=duration_s, timeout_s=duration_s + 600.0)
        return self.user.announce(spec, patience_s=60.0)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT)):
            self.clock.now = round(self.clock.now + DT, 6)
            for name, (task_id, end) in list(self.running.items()):
                if self.clock.now >= end:
                    del self.running[name]
                    self.log.append((self.clock.now, name, task_id, "done"))
                    self.members[name].complete(task_id)
            for name in sorted(self.members):
                self.members[name].step()
            self.user.step()

    def outcomes(self) -> dict[str, list[str]]:
        out: dict[str, list[str]] = defaultdict(list)
        for e in self.events:
            if e.kind == "outcome":
                out[e.task_id].append(str(e.detail["status"]))
        return out

    def check_never_two_at_once(self) -> None:
        holders: dict[str, str] = {}
        for _, robot, task, what in self.log:
            if what == "start":
                assert task not in holders, f"{task} started by {robot} while {holders.get(task)}"
                holders[task] = robot
            elif holders.get(task) == robot:
                del holders[task]


ALGORITHMS = ["cbba", "cbga"]


def test_registry_names_each_allocator() -> None:
    assert {"murdoch", "cbba", "cbga"} <= set(ALLOCATORS)
    assert allocator("cbga").name == "cbga"
    with pytest.raises(ValueError, match="expected one of murdoch, cbba, cbga"):
        allocator("no-such-allocator")


def test_state_crosses_the_bus_in_offer_numbers() -> None:
    msg = ConsensusMessage(KIND_CBBA, 1, 3.0, ((0, 1, 50.0), (2, 0, 40.0)),
                           (2.0, 3.0, float("-inf")))
    order = [4, 9, 17]
    chunks = state_chunks(msg, order)
    assert [e[0] for c in chunks for e in c.entries] == [4, 17]
    back, span = local_message(chunks[0], KIND_CBBA, [4, 17], silent=())
    assert back.entries == ((0, 1, 50.0), (1, 0, 40.0))
    assert span == (0, 2) and back.stamps[2] == float("-inf")
    dropped, _ = local_message(chunks[0], KIND_CBBA, [4, 17], silent={0})
    assert dropped.entries == ((0, 1, 50.0),)  # agent 0 fell silent: its bids are not taken


def test_a_large_state_travels_in_several_chunks_that_cover_every_offer() -> None:
    entries = tuple((j, j % 3, 100.0 - j) for j in range(100))
    msg = ConsensusMessage(KIND_CBBA, 0, 1.0, entries, (1.0, 0.0, 0.0))
    chunks = state_chunks(msg, list(range(0, 200, 2)))
    assert len(chunks) > 1
    for c in chunks:
        assert len(TEAM_CODEC.encode_frame("r0", 0, frozenset({"team.state"}), c)) <= 1400
    assert sum(len(c.entries) for c in chunks) == 100
    assert chunks[0].first_task == 0
    for a, b in pairwise(chunks):
        assert a.first_task + a.task_count == b.first_task


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("loss", [0.0, 0.2])
def test_tasks_arriving_over_time_are_each_done_once(algorithm: str, loss: float) -> None:
    team = Team(algorithm, loss=loss, seed=3)
    ids = []
    rng = random.Random(5)
    for _ in range(8):
        ids.append(team.offer("track", rng.uniform(0, 5), rng.uniform(0, 5), duration_s=4.0))
        team.run(rng.uniform(0.5, 3.0))
    team.run(120.0)
    outcomes = team.outcomes()
    assert {t: outcomes[t] for t in ids} == {t: ["completed"] for t in ids}
    team.check_never_two_at_once()
    done = [task for _, _, task, what in team.log if what == "done"]
    assert sorted(done) == sorted(ids)
    assert len({r for _, r, _, what in team.log if what == "done"}) > 1  # shared out


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_tasks_go_in_path_order_to_the_nearer_robot(algorithm: str) -> None:
    team = Team(algorithm, robots={"near": (0.0, 0.0), "far": (40.0, 0.0)})
    first = team.offer("track", 1.0, 0.0, duration_s=3.0)
    second = team.offer("track", 2.0, 0.0, duration_s=3.0)
    team.run(30.0)
    starts = [(robot, task) for _, robot, task, what in team.log if what == "start"]
    assert starts == [("near", first), ("near", second)]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_dead_robots_task_is_reallocated_and_its_bids_dropped(algorithm: str) -> None:
    team = Team(algorithm, loss=0.1, seed=1)
    task = team.offer("track", 5.0, 5.0, duration_s=30.0)
    team.run(5.0)
    (holder,) = list(team.running)
    team.kill(holder)
    team.run(80.0)
    assert team.outcomes()[task] == ["completed"]
    kinds = [e.kind for e in team.events if e.task_id == task]
    assert "reallocation" in kinds
    finisher = [r for _, r, t, what in team.log if what == "done" and t == task]
    assert finisher and finisher[0] != holder
    team.check_never_two_at_once()


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_dead_robots_queued_bids_are_dropped_after_its_silence(algorithm: str) -> None:
    team = Team(algorithm, seed=2, robots={"a": (0.0, 0.0), "b": (40.0, 0.0)})
    tasks = {team.offer("track", 0.0, 1.0, duration_s=30.0),
             team.offer("track", 0.0, 2.0, duration_s=30.0)}
    team.run(4.0)
    agent = team.members["b"].agent
    assert agent is not None
    assert "a" in team.running and 0 in set().union(*agent.winners_view())  # a queued one
    team.kill("a")
    team.run(200.0)
    assert 0 in team.members["b"].silent
    assert {t: team.outcomes()[t] for t in tasks} == {t: ["completed"] for t in tasks}
    assert {r for _, r, _, what in team.log if what == "done"} == {"b"}
    team.check_never_two_at_once()


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_restarted_robot_rejoins_and_takes_work(algorithm: str) -> None:
    team = Team(algorithm, robots={"a": (0.0, 0.0), "b": (20.0, 0.0)})
    team.kill("a")
    team.run(10.0)
    team.start("a")
    team.run(15.0)  # it learns the open offers from their repeats
    near_a = team.offer("track", 0.5, 0.0, duration_s=3.0)
    near_b = team.offer("track", 19.5, 0.0, duration_s=3.0)
    team.run(30.0)
    done = {t: r for _, r, t, what in team.log if what == "done"}
    assert done == {near_a: "a", near_b: "b"}
    assert all(0 not in m.silent for m in team.members.values())


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_robot_leaving_to_charge_gives_its_tasks_away(algorithm: str) -> None:
    team = Team(algorithm, robots={"a": (0.0, 0.0), "b": (30.0, 0.0)})
    tasks = {team.offer("track", 0.0, 1.0, duration_s=20.0),
             team.offer("track", 0.0, 2.0, duration_s=20.0)}
    team.run(3.0)
    busy = team.running["a"][0]  # both are near a: it plans both, runs one
    agent = team.members["a"].agent
    assert agent is not None and len(agent.path) == 1  # (the other one, queued)
    (queued,) = tasks - {busy}
    team.members["a"].set_subjects(())  # charging after this task: queue nothing more
    team.run(60.0)
    done = {t: r for _, r, t, what in team.log if what == "done"}
    assert done == {busy: "a", queued: "b"}


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_nobody_able_means_unachievable_after_backoff(algorithm: str) -> None:
    team = Team(algorithm)
    task = team.offer("grip", 1.0, 1.0, subjects=frozenset({"gripper", "mobile"}))
    team.run(90.0)
    assert team.outcomes()[task] == ["unachievable"]
    closes = [e for e in team.events if e.task_id == task and e.kind == "close"]
    assert len(closes) > 1 and all(e.detail["bids"] == 0 for e in closes)
    assert not team.log


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_cancelled_task_stops_its_executor(algorithm: str) -> None:
    team = Team(algorithm)
    task = team.offer("track", 1.0, 1.0, duration_s=50.0)
    team.run(5.0)
    assert any(t == task for t, _ in team.running.values())
    team.user.cancel(task, "withdrawn")
    team.run(2.0)
    assert not team.running
    assert team.outcomes()[task] == ["failed"]


def test_the_murdoch_allocator_builds_a_node() -> None:
    from murdoch.node import Node

    clock = Clock()
    bus = MemoryBus(clock, random.Random(0))
    started: list[Any] = []
    hooks = RobotHooks("r", frozenset({"camera"}), score=lambda n, p, t: 1.0,
                       knows=lambda n: True, on_start=started.append,
                       on_stop=lambda a, r: None)
    member = allocator("murdoch").robot(bus.endpoint("r"), clock, hooks)
    assert isinstance(member, Node)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_grant_that_finds_its_robot_gone_to_charge_is_given_back(algorithm: str) -> None:
    team = Team(algorithm, robots={"a": (0.0, 0.0), "b": (30.0, 0.0)})
    task = team.offer("track", 0.0, 1.0, duration_s=3.0)
    member = team.members["a"]
    for _ in range(40):  # until a has claimed, not yet been granted
        team.run(DT)
        if member.counters["claims"]:
            break
    assert member.counters["claims"] == 1 and not team.running
    member.set_subjects(())  # the battery policy sent it to charge meanwhile
    team.run(40.0)
    kinds = [e.kind for e in team.events if e.task_id == task]
    assert "reallocation" in kinds
    assert [r for _, r, t, what in team.log if what == "done"] == ["b"]
