"""Glue between one robot's `RobotAgent` and one MURDOCH `Node` (``murdoch-robot --mcast-port``).

One thread does everything in turn, so nothing here needs a lock: read one data round and run
the robot's behaviours (`RobotAgent.step`), then let the MURDOCH node receive, bid, renew and
report (`Node.step`). The node offers the robot's resource subjects (plus ``idle`` while it
holds no contract, and nothing while it charges), scores announcements with the robot's task
metrics, starts awarded tasks on the agent, and reports their completion or failure back to
the auctioneer. A running task that says which tasks it needs (the box watcher's ``need``
events) has them auctioned as its sub-tasks by this robot's own node. Time is simulation time
from the robot's data.
"""

from __future__ import annotations

import json
import logging
import random
from collections import deque
from typing import IO, Any

from behaviors.events import TASK_DONE, TASK_FAILED, TASK_STOPPED
from behaviors.library import TASKS
from murdoch.auction.messages import TaskSpec
from murdoch.node import Node
from murdoch.user_agent import RandomizedBackoff

log = logging.getLogger("murdoch-robot.link")


class MurdochLink:
    """Glue between one `RobotAgent` and one MURDOCH `Node` (owner thread only)."""

    def __init__(self, agent: Any, transport: Any, events: Any,
                 auction_log: IO[str] | None = None, *, subtask_patience_s: float = 60.0) -> None:
        self.agent = agent
        self._done_kinds = {TASK_DONE: "done", TASK_FAILED: "failed", TASK_STOPPED: "stopped"}
        self._finished: deque[tuple[str, str, str]] = deque(maxlen=64)
        self._needs: deque[tuple[str, tuple[str, ...]]] = deque(maxlen=64)
        self._heading_rad: float | None = None  # which way the watched box is to go
        self._current: str | None = None
        self._current_params: dict[str, Any] = {}
        self._subtasks: dict[str, str] = {}  # task name -> open sub-task id
        self._patience_s = subtask_patience_s
        self._auction_log = auction_log
        events.add_sink(self._on_event)
        self.node = Node(
            transport, self._now, agent_id=agent.name, subjects=agent.subjects(),
            metric=self._metric, on_start=self._on_start, on_stop=self._on_stop,
            on_outcome=self._on_outcome, observer=self._observe,
            backoff=RandomizedBackoff(random.Random(agent.name), base_s=2.0, cap_s=10.0),
        )

    def _observe(self, event: Any) -> None:
        if self._auction_log is not None:
            self._auction_log.write(json.dumps(event.to_dict(), default=str) + "\n")
            self._auction_log.flush()

    def _on_outcome(self, outcome: Any) -> None:
        # an outcome of a sub-task this robot announced (e.g. a pushing task for the box)
        if self._subtasks.get(outcome.name) == outcome.task_id:
            del self._subtasks[outcome.name]
        if outcome.status == "unachievable" and outcome.parent == self._current:
            assert self._current is not None
            task_id = self._current
            self._current = None
            self.agent.stop_task(f"sub-task {outcome.name} unachievable")
            self.node.fail(task_id, f"unachievable: nobody could do {outcome.name}")

    def _now(self) -> float:
        return float(self.agent.status().time_s)

    def _metric(self, announce: Any) -> float | None:
        try:
            return self.agent.evaluate(announce.name, dict(announce.params))
        except Exception as exc:  # an unknown task or bad parameters: do not bid
            log.info("not bidding on %s %s: %s", announce.name, announce.task_id, exc)
            return None

    def _on_start(self, contract: Any) -> None:
        a = contract.announce
        self._current = a.task_id
        self._current_params = dict(a.params)
        self.agent.start_task(a.name, dict(a.params), a.task_id)

    def _on_stop(self, contract: Any, reason: str) -> None:
        if self._current == contract.task_id:
            self._current = None
            self.agent.stop_task(reason)
            self._cancel_subtasks(reason)

    def _cancel_subtasks(self, reason: str) -> None:
        now = self._now()
        for task_id in list(self._subtasks.values()):
            for subjects, message in self.node.auctioneer.cancel(task_id, now, reason):
                self.node.transport.publish(subjects, message)
        self._subtasks.clear()

    def _on_event(self, event: Any) -> None:
        # called from agent.step(), on this same thread
        if event.kind in self._done_kinds and event.task_id:
            reason = dict(event.detail).get("reason", "")
            self._finished.append((event.task_id, self._done_kinds[event.kind], str(reason)))
        elif event.kind == "need" and event.task_id:
            detail = dict(event.detail)
            tasks = detail.get("tasks", ())
            self._needs.append((event.task_id, tuple(str(t) for t in tasks)))
            if isinstance(detail.get("heading_rad"), (int, float)):
                self._heading_rad = float(detail["heading_rad"])

    def _announce_needs(self) -> None:
        """A running task (the box watcher) said which tasks it needs: auction them as its
        sub-tasks, one open auction per task name."""
        while self._needs:
            parent, names = self._needs.popleft()
            if parent != self._current:
                continue
            for name in names:
                if name in self._subtasks or name not in TASKS:
                    continue
                spec = TASKS[name]
                params: dict[str, Any] = {
                    "colour": self._current_params.get("colour", "orange")}
                if self._heading_rad is not None:
                    params["heading_rad"] = round(self._heading_rad, 3)
                sub = TaskSpec(name, spec.subjects, params, duration_s=8.0, bid_window_s=0.5,
                               renew_period_s=1.0, contract_timeout_s=5.0, abandon_after_s=5.0,
                               timeout_s=60.0, parent=parent)
                self._subtasks[name] = self.node.announce(sub, patience_s=self._patience_s)

    def step(self) -> None:
        self.agent.step()
        while self._finished:
            task_id, how, reason = self._finished.popleft()
            if task_id != self._current:
                continue  # a task we were told to stop, or not a contract
            self._current = None
            self._cancel_subtasks(f"parent {how}")
            if how == "done":
                self.node.complete(task_id)
            else:
                self.node.fail(task_id, reason or how)
        self._announce_needs()
        subjects = frozenset(self.agent.subjects())
        if subjects != self.node.subjects:
            self.node.set_subjects(subjects)  # none while charging
        self.node.step(0.0)

    def close(self) -> None:
        self.node.close()
