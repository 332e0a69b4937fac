"""The contract checker: a short scripted team that any allocator must get through (pure).

`run_contract_check(allocator)` builds the allocator's user and four robots on an in-memory
bus with a fake clock (`murdoch.memory_bus`), runs a script and checks the team-member
contract (`murdoch.execution`) from the outside, raising `murdoch.plugin.ContractError`
with the rule broken (`ContractError`):

1. two tasks arrive while every robot is free: each is started within `GRANT_WITHIN_S`;
2. no robot ever runs two tasks, and no task ever runs on two robots at once;
3. the robot executing the first task is killed: the task is started again by another robot;
4. a task that needs a device no robot has ends `unachievable`, never started;
5. a robot leaves to charge (it gives its task back and offers nothing): its task is started
   again by another robot, and it is given nothing until it comes back;
6. every task ends with exactly one outcome, and the robots' tasks all end completed;
7. the same script gives the same events (the decisions are deterministic).
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from typing import Any

from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.auction.messages import AuctionEvent
from murdoch.auction.timing import USER_TASK
from murdoch.manual_clock import ManualClock
from murdoch.member import TeamMember
from murdoch.memory_bus import MemoryBus
from murdoch.user_agent import RandomizedBackoff

DT_S = 0.1
GRANT_WITHIN_S = 15.0
PLACES = {"r0": (0.0, 0.0), "r1": (6.0, 0.0), "r2": (0.0, 6.0), "r3": (6.0, 6.0)}
SUBJECTS = frozenset({"mobile", "camera"})


class ContractError(AssertionError):
    """An allocator broke a rule of the contract; the message names the rule."""


def _broken(rule: str, detail: str) -> ContractError:
    return ContractError(f"rule broken: {rule} ({detail})")


class _Team:
    """The allocator's user and four robots that run each task for its duration."""

    def __init__(self, allocator: Allocator) -> None:
        self.allocator = allocator
        self.clock = ManualClock()
        self.bus = MemoryBus(self.clock, random.Random(0))
        self.events: list[AuctionEvent] = []
        self.user = allocator.user(
            self.bus.endpoint("user", allocator.codec), self.clock,
            UserHooks("user", self.events.append,
                      RandomizedBackoff(random.Random(0), base_s=5.0, cap_s=20.0),
                      locate=lambda name, p: (float(p["x"]), float(p["y"]))))
        self.robots: dict[str, TeamMember] = {}
        self.running: dict[str, tuple[str, float]] = {}  # robot -> (task, ends at)
        self.log: list[tuple[float, str, str, str]] = []  # (t, robot, task, start|stop)
        self.away: set[str] = set()
        for name in PLACES:
            self._start(name)

    def _start(self, name: str) -> None:
        def on_start(a: Assignment) -> None:
            if name in self.running:
                raise _broken("a robot runs one task at a time",
                              f"{name} was given {a.task_id} while running "
                              f"{self.running[name][0]}")
            if name in self.away:
                raise _broken("a robot that left the team is given nothing",
                              f"{name} was given {a.task_id} while charging")
            holders = [r for r, (t, _) in self.running.items() if t == a.task_id]
            if holders:
                raise _broken("a task runs on one robot at a time",
                              f"{a.task_id} given to {name} while {holders[0]} runs it")
            self.running[name] = (a.task_id, self.clock.now_s + float(a.params["duration_s"]))
            self.log.append((self.clock.now_s, name, a.task_id, "start"))

        def on_stop(a: Assignment, reason: str) -> None:
            if self.running.get(name, ("",))[0] == a.task_id:
                del self.running[name]
                self.log.append((self.clock.now_s, name, a.task_id, "stop"))

        def score(kind: str, params: Mapping[str, Any], task_id: str) -> float:
            x, y = PLACES[name]
            return -math.hypot(float(params["x"]) - x, float(params["y"]) - y)

        hooks = RobotHooks(name, SUBJECTS, score=score, knows=lambda kind: kind == "visit",
                           on_start=on_start, on_stop=on_stop, position=lambda: PLACES[name],
                           team=tuple(PLACES),
                           backoff=RandomizedBackoff(random.Random(name), base_s=2.0, cap_s=10.0))
        self.robots[name] = self.allocator.robot(self.bus.endpoint(name, self.allocator.codec),
                                                 self.clock, hooks)

    def offer(self, x: float, y: float, subjects: frozenset[str] = frozenset({"mobile"}),
              duration_s: float = 20.0, patience_s: float = 40.0) -> str:
        spec = USER_TASK.task("visit", subjects, {"x": x, "y": y, "duration_s": duration_s},
                              duration_s=duration_s, timeout_s=duration_s + 600.0)
        return self.user.announce(spec, patience_s=patience_s)

    def kill(self, name: str) -> None:
        self.robots.pop(name).close()
        self.bus.detach(name)
        if name in self.running:
            self.log.append((self.clock.now_s, name, self.running.pop(name)[0], "stop"))

    def leave(self, name: str) -> None:
        """The robot goes to charge: it gives its task back and offers nothing."""
        self.away.add(name)
        if name in self.running:
            task_id, _ = self.running.pop(name)
            self.log.append((self.clock.now_s, name, task_id, "stop"))
            self.robots[name].abandon(task_id, "battery low")
        self.robots[name].set_subjects(())

    def rejoin(self, name: str) -> None:
        self.away.discard(name)
        self.robots[name].set_subjects(SUBJECTS)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT_S)):
            self.clock.now_s = round(self.clock.now_s + DT_S, 6)
            for name, (task_id, end) in list(self.running.items()):
                if self.clock.now_s >= end:
                    del self.running[name]
                    self.robots[name].complete(task_id)
            for name in sorted(self.robots):
                self.robots[name].step()
            self.user.step()

    def starts(self, task_id: str) -> list[tuple[float, str]]:
        return [(t, r) for t, r, task, what in self.log if task == task_id and what == "start"]

    def outcomes(self, task_id: str) -> list[str]:
        return [str(e.detail["status"]) for e in self.events
                if e.kind == "outcome" and e.task_id == task_id]


def _script(allocator: Allocator) -> list[str]:
    team = _Team(allocator)
    first, second = team.offer(1.0, 1.0), team.offer(5.0, 5.0)
    team.run(GRANT_WITHIN_S)
    for task_id in (first, second):
        if not team.starts(task_id):
            raise _broken("a task is given to a free capable robot",
                          f"{task_id} not started within {GRANT_WITHIN_S:g} s with four "
                          f"robots free")
    killed = team.starts(first)[-1][1]
    team.kill(killed)
    impossible = team.offer(3.0, 3.0, subjects=frozenset({"laser"}), patience_s=30.0)
    team.run(USER_TASK.contract_timeout_s + USER_TASK.abandon_after_s + GRANT_WITHIN_S)
    if not [r for _, r in team.starts(first) if r != killed]:
        raise _broken("a silent executor's task is given to another robot",
                      f"{first} not started again after {killed} was killed")
    if team.starts(impossible):
        raise _broken("a task goes only to a robot that offers what it needs",
                      f"{impossible} (needs laser) was started")
    third = team.offer(2.0, 4.0)
    team.run(GRANT_WITHIN_S)
    holders = [r for r, (t, _) in team.running.items() if t == third]
    if not holders:
        raise _broken("a task is given to a free capable robot",
                      f"{third} not started within {GRANT_WITHIN_S:g} s")
    leaving = holders[0]
    team.leave(leaving)
    team.run(GRANT_WITHIN_S + 5.0)
    if not [r for _, r in team.starts(third) if r != leaving]:
        raise _broken("a task given back (abandoned) is given to another robot",
                      f"{third} not started again after {leaving} left to charge")
    team.rejoin(leaving)
    team.run(120.0)
    if team.outcomes(impossible) != ["unachievable"]:
        raise _broken("a task nobody can do ends unachievable",
                      f"{impossible} ended {team.outcomes(impossible) or 'never'}")
    for task_id in (first, second, third):
        if team.outcomes(task_id) != ["completed"]:
            raise _broken("every task ends with exactly one outcome",
                          f"{task_id} ended {team.outcomes(task_id) or 'never'}, expected "
                          f"completed once")
    refused = getattr(team.user, "counters", {}).get("refused", 0)
    if refused:
        raise _broken("a decision names open tasks and free capable robots, each once",
                      f"{refused} assignment(s) refused")
    return [repr(sorted(e.to_dict().items())) for e in team.events]


def run_contract_check(allocator: Allocator) -> None:
    """Run the script twice; raise `ContractError` naming the first rule broken."""
    try:
        first = _script(allocator)
        again = _script(allocator)
    except AssertionError:
        raise
    except Exception as exc:  # the allocator's own code raised
        raise _broken("the allocator's code does not raise",
                      f"{allocator.name}: {type(exc).__name__}: {exc}") from exc
    if first != again:
        at = next((i for i, (a, b) in enumerate(zip(first, again, strict=False)) if a != b),
                  min(len(first), len(again)))
        raise _broken("the same script gives the same decisions",
                      f"{allocator.name}'s events differ from event {at + 1} on")
