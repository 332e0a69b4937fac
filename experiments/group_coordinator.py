"""The runner's coordinator of group tasks, on the serving thread (the I/O edge of
`experiments.group_tasks`).

A group task is introduced by the user like any other task (`task_introduced`, its needs in
`params`, `group` true). With an allocator that gives tasks to single robots the coordinator
hands its members to the team as separate tasks (`task_introduced`, `source` "group",
`parent` the group), reintroduced with backoff like the user's own. With an allocator that
takes group tasks whole (`whole`: CBGA) it hands the team one task instead, the group's own
kind and parameters (`source` "group", `parent` the group), whose robots form the group among
themselves (`murdoch.allocators.group_offers`). At every tick boundary
it judges each open group from the simulation's ground truth (`PairJudge`, over the robots
whose controllers run: a killed or frozen robot left standing on a spot holds nothing): the
group ends
`completed` once each spot has held its own robot for the hold time (the robots in
`robots`), `unachievable` when a member turned out unachievable, `failed` when a member
ended first or the deadline passed; the members still open are then withdrawn. Members that
go on after their group was achieved end as their robots report.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field
from typing import Any

from experiments import events as ev
from experiments.group_tasks import GROUP_KINDS, GroupTask, PairJudge, group_outcome
from experiments.task_source import PlannedTask


@dataclass
class OpenGroup:
    task_id: str
    group: GroupTask
    introduced_t: float
    judge: PairJudge
    members: dict[str, str | None] = field(default_factory=dict)
    """member task id -> its outcome (None: still open)."""


def whole_task_spec(group: GroupTask, parent: str) -> Any:
    """The announcement of a group task taken whole: the group's kind, the union of its
    members' equipment as subjects, the group's parameters."""
    from murdoch.auction.timing import USER_TASK

    subjects = frozenset().union(*(m.equipment for m in group.members))
    return USER_TASK.task(group.kind, subjects, group.as_params(), duration_s=group.duration_s,
                          timeout_s=group.duration_s + 600.0, parent=parent)


def member_task_spec(kind: str, params: Mapping[str, Any], parent: str) -> Any:
    """The announcement of one member of a group task (a task of the robots' library)."""
    from behaviors.library import TASKS
    from murdoch.auction.timing import USER_TASK

    duration = float(params.get("duration_s", 0.0))
    return USER_TASK.task(kind, TASKS[kind].subjects, params, duration_s=duration,
                          timeout_s=duration + 600.0, parent=parent)


class GroupCoordinator:
    """Introduces group tasks, hands out their members and judges them."""

    def __init__(self, *, rec: Any, node: Any, sim: Any, mobile: frozenset[str],
                 introduced: set[str], finished: set[str], patience_s: float,
                 member_spec: Callable[[str, Mapping[str, Any], str], Any] = member_task_spec,
                 whole: bool = False) -> None:
        self.rec = rec
        self.node = node
        self.sim = sim
        self.mobile = tuple(sorted(mobile))
        self.introduced = introduced
        self.finished = finished
        self.patience_s = patience_s
        self.member_spec = member_spec
        self.whole = whole
        self.open: dict[str, OpenGroup] = {}
        self.member_of: dict[str, str] = {}
        self.count = 0

    @staticmethod
    def handles(kind: str) -> bool:
        return kind in GROUP_KINDS

    def introduce(self, planned: PlannedTask, now: float) -> str:
        group = GroupTask.from_params(planned.kind, planned.params)
        self.count += 1
        task_id = f"group-{self.count}"
        self.rec.event(now, ev.TASK_INTRODUCED, task=task_id, task_kind=planned.kind,
                       params=group.as_params(), source="user", group=True)
        self.introduced.add(task_id)
        entry = OpenGroup(task_id, group, now, PairJudge(group))
        self.open[task_id] = entry
        if self.whole:
            handed = [(whole_task_spec(group, task_id), group.kind, group.as_params())]
        else:
            handed = [(self.member_spec(m.kind, m.params, task_id), m.kind, dict(m.params))
                      for m in group.members]
        for spec, kind, params in handed:
            member_id = str(self.node.announce(spec, patience_s=self.patience_s))
            self.rec.event(now, ev.TASK_INTRODUCED, task=member_id, task_kind=kind,
                           params=params, source="group", parent=task_id)
            self.introduced.add(member_id)
            entry.members[member_id] = None
            self.member_of[member_id] = task_id
        return task_id

    def on_outcome(self, task_id: str, outcome: str, now: float) -> None:
        """A task ended; a member's end may end its group (judged at the next step)."""
        group_id = self.member_of.get(task_id)
        if group_id is not None and group_id in self.open:
            self.open[group_id].members[task_id] = outcome

    def step(self, now: float, down: Collection[str] = ()) -> None:
        """Judge the open groups at a tick boundary; robots `down` (killed, exited,
        frozen, retired: no controller watches through them) hold no spot."""
        if not self.open:
            return
        positions = {r: tuple(self.sim.get_pose(r)[:2]) for r in self.mobile if r not in down}
        for task_id in sorted(self.open):
            entry = self.open[task_id]
            placed = entry.judge.update(now, positions)
            if placed is not None:
                self._end(entry, now, ev.COMPLETED, "both members in place", robots=placed,
                          in_place_s=round(now - entry.introduced_t, 3))
                continue
            ended = [o for o in entry.members.values() if o is not None]
            outcome = group_outcome(ended)
            if outcome is not None:
                self._end(entry, now, outcome,
                          "unachievable: a member found no robot" if outcome == ev.UNACHIEVABLE
                          else "a member ended before the group was in place")
            elif now - entry.introduced_t >= entry.group.deadline_s:
                self._end(entry, now, ev.FAILED, "members not in place together by the "
                          f"deadline ({entry.group.deadline_s:g} s)")

    def _end(self, entry: OpenGroup, now: float, outcome: str, reason: str,
             **fields: Any) -> None:
        del self.open[entry.task_id]
        robots = fields.pop("robots", ())
        self.rec.event(now, ev.TASK_OUTCOME, task=entry.task_id, outcome=outcome,
                       reason=reason, robots=list(robots), **fields)
        self.finished.add(entry.task_id)
        if outcome != ev.COMPLETED:
            open_members = set(self.node.open_tasks())
            for member_id, member_outcome in sorted(entry.members.items()):
                if member_outcome is None and member_id in open_members:
                    self.node.cancel(member_id, f"group {entry.task_id} {outcome}")
