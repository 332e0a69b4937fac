"""The runner's own part in a run: one participant of the tick protocol, on the serving thread.

`RunLoop.on_round` is `PlayerServer`'s round hook: it runs on the serving thread at every tick
boundary, with the simulation holding the state of the round about to go out (in lockstep:
once every robot has finished the previous tick and asked for this one). There it is the
"user" of the MURDOCH paper and the referee, all on simulation time:

1. declares how many datagrams its node has sent (through the previous tick) into the team
   clock, and acts on the robots' datagrams of the previous tick in tick order
   (`settle_tick`; in real time it reads whatever has arrived);
2. reads what the robots wrote (events, auction events) for the previous tick, robots in
   name order;
3. applies the fault schedule entries due at this tick (kill, restart, switch off, switch
   on; for soak runs also freeze and thaw, switch-off for good, charger off and on, and task
   bursts); a robot started (or continued) here is expected by the lockstep before the next
   tick;
4. introduces due tasks, watches the goal (boxpush), ends the run when its end is decided;
5. steps its MURDOCH node (auctions, awards, renewals, reintroduction with backoff).

Nothing here looks at the wall clock except the bound on waiting for declared datagrams,
which can only end the run with an error. The main thread does the wall-clock work
(progress display, memory samples into processes.jsonl, signals).
"""

from __future__ import annotations

import logging
from collections import Counter, defaultdict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

from experiments import boxpush as bp
from experiments import events as ev
from experiments.observe import JsonlTail, robot_event_to_run_events
from experiments.task_source import PlannedTask

log = logging.getLogger("murdoch.run")

PATIENCE_S = 300.0
DEATH_CHECK_TICKS = 10
"""How often (in ticks) the runner looks for robot processes that died by themselves."""
BOXPUSH_LINGER_S = 3.0
"""After the box's fate is decided, the run goes on this long for the last reports."""
BOX_PROGRESS_PERIOD_S = 1.0
"""boxpush: how often the box's distance to the goal goes into the events."""


@dataclass(frozen=True)
class Fault:
    """One entry of the fault schedule: `action` on `robot` at simulation time `t_s`.

    Actions: kill, restart, switch-off, switch-on (boxpush), and for soak runs freeze, thaw
    (a robot's process stopped and continued, `hold_clock`), retire (switched off for good),
    charger-off, charger-on (`robot` names the charger) and burst (`count` tasks at once from
    the burst source)."""

    t_s: float
    action: str
    robot: str
    count: int = 0

    def label(self) -> str:
        return f"{self.robot}@{self.t_s:g}s"


class RobotProcesses(Protocol):
    """What the loop needs from the runner's process supervision."""

    def names(self) -> list[str]: ...

    def start(self, name: str) -> int:
        """Start the robot's process (again); returns its pid."""
        ...

    def kill(self, name: str) -> int | None:
        """Kill the robot's process at once; returns the pid it had (None: not running)."""
        ...

    def exited(self) -> list[tuple[str, int, int]]:
        """(name, pid, exit code) of processes that ended by themselves since last asked."""
        ...

    def pause(self, name: str, paused: bool) -> int | None:
        """Stop (SIGSTOP) or continue (SIGCONT) the robot's process; its pid (None: not
        running)."""
        ...


@dataclass
class RunState:
    """What the loop decided, for the main thread (read after the serving thread ended)."""

    introduced: set[str] = field(default_factory=set)
    finished: set[str] = field(default_factory=set)
    unachievable: dict[str, str] = field(default_factory=dict)
    goal_outcome: str | None = None
    end_reason: str | None = None
    error: BaseException | None = None
    last_t: float = 0.0
    closed: bool = False


class RunLoop:
    def __init__(
        self,
        *,
        rec: Any,
        sim: Any,
        node: Any,
        transport: Any,
        processes: RobotProcesses,
        tails: dict[str, tuple[JsonlTail, JsonlTail]],
        planned: Iterator[PlannedTask | None],
        task_subjects: Callable[[str], tuple[str, ...]],
        task_spec: Callable[..., Any],
        duration_s: float,
        faults: list[Fault],
        expect: Callable[[str], None] | None,
        team_clock: Any | None,
        wait_clock: Callable[[], float],
        request_stop: Callable[[], None],
        boxpush: tuple[Any, Any] | None = None,
        mobile: frozenset[str] = frozenset(),
        spec: Any = None,
        place: Callable[..., None] | None = None,
        goal_plan: bp.GoalPlan | None = None,
        hold_clock: Callable[[str, bool], None] | None = None,
        burst: Iterator[PlannedTask | None] | None = None,
    ) -> None:
        self.rec = rec
        self.sim = sim
        self.node = node
        self.transport = transport
        self.processes = processes
        self.tails = dict(sorted(tails.items()))
        self.planned = planned
        self.next_task = next(planned)
        self.task_subjects = task_subjects
        self.task_spec = task_spec
        self.duration_s = duration_s
        self.faults = sorted(faults, key=lambda f: (f.t_s, f.robot, f.action))
        self.expect = expect
        self.team_clock = team_clock
        self.wait_clock = wait_clock
        self.request_stop = request_stop
        self.goal_watch: Any = boxpush[0] if boxpush is not None else None
        self.actions: Any = boxpush[1] if boxpush is not None else None
        self.mobile = mobile
        self.spec = spec
        self.place = place
        self.goal_plan = goal_plan or bp.GoalPlan()
        self.retargets = sorted(self.goal_plan.retargets)
        self.goal_marker = self.goal_watch.bg.goal if self.goal_watch is not None else None
        self.next_progress_s = 0.0
        self.interval_s = float(sim.interval_s)
        self.state = RunState()
        self.announced_at: dict[str, float] = {}
        self.main_task: str | None = None
        self.task_params: dict[str, Any] = {}
        self.end_after_s: float | None = None
        self.switched_off: dict[str, float] = {}
        self.busy_killed: list[str] = []
        # boxpush: which end each pusher pushes now and pushed before; switch-ons waiting
        self.task_kind: dict[str, str] = {}
        self.push_holder: dict[str, tuple[str, str]] = {}  # robot -> (end, task)
        self.push_task: dict[str, str] = {}  # task -> robot
        self.pushed: set[str] = set()
        self.ends_before: dict[str, Counter[str]] = defaultdict(Counter)
        self.worked_end: dict[str, str] = {}
        self.pending_on: dict[str, float] = {}
        self.scheduled_down: set[str] = set()
        self.hold_clock = hold_clock
        self.burst = burst
        self.frozen: set[str] = set()
        self.busy_frozen: list[str] = []
        self.episodes: list[str | None] = []

    # -- the hook -------------------------------------------------------------------------------
    def on_round(self) -> None:
        if self.state.closed:
            return
        try:
            self._round()
        except Exception as exc:  # the run cannot go on exactly: end it, say why
            log.exception("the run's own participant failed")
            self.state.error = exc
            self.state.end_reason = "error"
            self.request_stop()

    def _round(self) -> None:
        now = float(self.sim.time_s)
        tick = round(now / self.interval_s)
        self.state.last_t = now
        core = self.transport.core
        if self.team_clock is not None:
            self.team_clock.declare(core.sender_key, core.sent_count)
            self.transport.settle_tick(tick, self.team_clock.table(),
                                       wait_clock=self.wait_clock)
        else:
            self.transport.poll(0.0)
        self._drain_robots()
        if tick % DEATH_CHECK_TICKS == 0:
            self._deaths(now)
        self._faults(now)
        if self.pending_on:
            self._pending_switch_ons(now)
        self._introduce(now)
        self._goal(now)
        self._referee(now)
        self.node.step(0.0)
        self.rec.advance(now)
        if now >= self.duration_s - 1e-9 and self.state.end_reason is None:
            self.state.end_reason = "completed"
        if self.state.end_reason is not None:
            # the end is decided at a tick boundary: what the robots did before it is all
            # read, what they do after it is not part of the run
            self.close_open_tasks(now)
            self.request_stop()

    # -- what the robots wrote --------------------------------------------------------------
    def _drain_robots(self) -> None:
        for events, auctions in self.tails.values():
            for d in events.read_new():
                for e in robot_event_to_run_events(d):
                    self.rec.event(e.pop("t"), e.pop("kind"), **e)
            for d in auctions.read_new():
                if "time_s" in d and "kind" in d:
                    self.on_auction_event(d)

    def on_auction_event(self, d: dict[str, Any]) -> None:
        """An auctioneer's event (the runner's own or a robot's) as run events."""
        kind, task_id, t = d.get("kind"), str(d.get("task_id")), float(d["time_s"])
        st = self.state
        if kind == "announce":
            self.task_kind.setdefault(task_id, str(d.get("name", "")))
            if task_id not in self.announced_at and d.get("agent") != "user":
                self.rec.event(t, ev.TASK_INTRODUCED, task=task_id, task_kind=d.get("name", ""),
                               source=d.get("agent"))
                st.introduced.add(task_id)
            self.announced_at[task_id] = t
        elif kind == "close" and not d.get("bids"):
            self.rec.event(t, ev.NO_BID, task=task_id, attempt=int(d.get("attempt", 0)))
        elif kind == "award":
            latency = t - self.announced_at.get(task_id, t)
            self.rec.event(t, ev.AWARD, task=task_id, robot=d.get("winner"),
                           bid=d.get("score"), latency_s=round(latency, 4))
            self._push_award(task_id, str(d.get("winner")))
        elif kind == "reallocation":
            self._push_over(task_id)
            self.rec.event(t, ev.REALLOCATION, task=task_id, from_robot=d.get("winner"),
                           reason=d.get("reason", ""))
        elif kind in ("decline", "expired"):
            # a bidder refused an award (busy, bid expired) or gave up waiting for one: never
            # silent (docs/murdoch.md, late awards)
            self.rec.event(t, ev.BID_DECLINED if kind == "decline" else ev.BID_EXPIRED,
                           task=task_id, robot=d.get("agent"),
                           **({"reason": d["reason"]} if "reason" in d else {}))
        elif kind == "outcome" and task_id not in st.finished:
            self._push_over(task_id)
            why = str(d.get("reason", ""))
            if d.get("status") == "unachievable" or why.startswith("unachievable"):
                st.unachievable[task_id] = why or "unachievable"
            self.rec.event(t, ev.TASK_OUTCOME, task=task_id, outcome=d.get("status"),
                           robot=d.get("winner"), reason=d.get("reason", ""))
            st.finished.add(task_id)

    def on_message(self, envelope: Any) -> None:
        """Every MURDOCH message the runner hears, at the time of its sender's tick."""
        msg = envelope.message
        t = (envelope.tick * self.interval_s if envelope.tick >= 0
             else float(self.sim.time_s))
        fields = {"task": getattr(msg, "task_id", None)} if hasattr(msg, "task_id") else {}
        self.rec.event(round(t, 6), ev.MESSAGE, msg_kind=envelope.kind,
                       sender=envelope.sender, bytes=envelope.size_bytes, **fields)

    # -- processes ----------------------------------------------------------------------------
    def _deaths(self, now: float) -> None:
        for name, pid, code in self.processes.exited():
            if name in self.scheduled_down:
                continue
            self.scheduled_down.add(name)
            self.rec.event(now, ev.ROBOT_FAILURE, robot=name, reason="exited", exit_code=code)
            self.rec.note_process(now, "exited", name, pid, exit_code=code)

    def _faults(self, now: float) -> None:
        while self.faults and self.faults[0].t_s <= now + 1e-9:
            fault = self.faults.pop(0)
            name = fault.robot
            if name == "same":
                # the robot the latest busy kill or freeze picked (None: it found nobody)
                picked_last = self.episodes.pop() if self.episodes else None
                if picked_last is None:
                    self.rec.event(now, ev.FAULT_SKIPPED, action=fault.action, robot="same",
                                   reason="its kill or freeze found nobody busy")
                    continue
                name = picked_last
            elif name == "busy":
                picked = self.busy_frozen if fault.action in ("freeze", "thaw") else \
                    self.busy_killed
                if fault.action in ("kill", "freeze"):
                    working = [r for r, st in sorted(self.rec.robot_states().items())
                               if st == "working" and r in self.mobile
                               and r not in self.scheduled_down and r not in self.frozen]
                    if not working:
                        self.rec.event(now, ev.FAULT_SKIPPED, action=fault.action,
                                       robot="busy", reason="no robot holds a task")
                        self.episodes.append(None)
                        continue
                    picked.append(working[0])
                    self.episodes.append(working[0])
                    name = working[0]
                elif picked:
                    name = picked[-1]
                else:
                    self.rec.event(now, ev.FAULT_SKIPPED, action=fault.action, robot="busy",
                                   reason="no robot was killed as busy"
                                   if fault.action == "restart"
                                   else "no robot was frozen as busy")
                    continue
            if fault.action == "burst":
                self._burst(name, now, fault.count)
            else:
                getattr(self, "_" + fault.action.replace("-", "_"))(name, now)

    def _kill(self, name: str, now: float) -> None:
        self._unfreeze_quietly(name, resume=False)
        self.scheduled_down.add(name)
        pid = self.processes.kill(name)
        self.rec.event(now, ev.ROBOT_FAILURE, robot=name, reason="killed")
        self.rec.note_process(now, "killed", name, pid)

    def _restart(self, name: str, now: float) -> None:
        self._start(name, now)
        self.rec.event(now, ev.ROBOT_RESTART, robot=name)

    def _start(self, name: str, now: float) -> int:
        self._unfreeze_quietly(name, resume=False)
        self.processes.kill(name)  # a process still running is replaced
        pid = self.processes.start(name)
        self.rec.note_process(now, "started", name, pid)
        self.scheduled_down.discard(name)
        if self.expect is not None:
            self.expect(name)
        return pid

    def _switch_off(self, name: str, now: float) -> None:
        gw, actions = self.goal_watch, self.actions
        assert gw is not None and actions is not None and self.place is not None
        self.scheduled_down.add(name)
        pid = self.processes.kill(name)
        self.rec.note_process(now, "switched-off", name, pid)
        box_pose = gw.box_pose
        xy = gw.robot_poses.get(name, (0.0, 0.0, 0.0))
        side = bp.side_of(box_pose, xy[:2]) if box_pose is not None else 0.0
        self.switched_off[name] = side
        # the end it worked: the end of most of its pushes so far (else where it stands)
        worked = [(e, n) for e, n in self.ends_before[name].most_common() if e in bp.OTHER_END]
        if worked and (len(worked) == 1 or worked[0][1] > worked[1][1]):
            self.worked_end[name] = worked[0][0]
        elif box_pose is not None:
            self.worked_end[name] = bp.end_at(box_pose, gw.goal_xy, xy[:2])
        self.ends_before[name].clear()
        self.push_holder.pop(name, None)
        spot = bp.park_pose(self.spec, sorted(self.processes.names()).index(name))
        place = self.place
        actions.put(lambda s, n=name, p=spot: place(s, n, p))
        self.rec.event(now, ev.ROBOT_SWITCH_OFF, robot=name, side_m=round(side, 3),
                       end=self.worked_end.get(name))

    def _switch_on(self, name: str, now: float) -> None:
        """Switch a pusher back on behind the other end from the one it worked before. The
        remaining pusher must be working that old end (else the returning pusher, free while
        the other is busy, would be given its old end's pushes again): the switch-on waits,
        tick by tick, until it is, or at most `SWITCH_ON_WAIT_S`."""
        self.pending_on[name] = now
        self._pending_switch_ons(now)

    def _pending_switch_ons(self, now: float) -> None:
        for name, asked_at in sorted(self.pending_on.items()):
            old_end = self.worked_end.get(name, "left")
            others = [r for r in self.push_holder
                      if r != name and r not in self.switched_off]
            ready = any(self.push_holder[r][0] == old_end for r in others)
            waited_out = now >= asked_at + bp.SWITCH_ON_WAIT_S - 1e-9
            if ready or waited_out or not self._pushers_left(name):
                del self.pending_on[name]
                self._place_and_start(name, now, bp.OTHER_END[old_end], ready, asked_at)

    def _pushers_left(self, name: str) -> bool:
        return any(r not in self.switched_off and r != name for r in self.pushed)

    def _place_and_start(self, name: str, now: float, end: str, other_ready: bool,
                         asked_at: float) -> None:
        gw, actions = self.goal_watch, self.actions
        assert gw is not None and actions is not None and self.place is not None
        self.switched_off.pop(name, None)
        box_pose = gw.box_pose
        assert box_pose is not None
        offset = bp.end_offset(box_pose, gw.goal_xy, end, gw.bg)
        pose = bp.return_pose(box_pose, gw.goal_xy, offset, gw.bg)
        start = next(r.pose for r in self.spec.robots if r.name == name)
        odo = bp.odometry_at((start[0], start[1], start[2]), pose)
        place = self.place
        # placed by hand and told where it is: odometry stays in the shared frame
        actions.put(lambda s, n=name, p=pose, o=odo: place(s, n, p, o))
        self._start(name, now)
        self.rec.event(now, ev.ROBOT_SWITCH_ON, robot=name, x=round(pose[0], 3),
                       y=round(pose[1], 3), yaw=round(pose[2], 3), end=end,
                       other_at_old_end=other_ready, asked_t=round(asked_at, 3))

    def _push_award(self, task_id: str, robot: str) -> None:
        end = bp.PUSH_ENDS.get(self.task_kind.get(task_id, ""))
        if end is None:
            return
        self.push_holder[robot] = (end, task_id)
        self.push_task[task_id] = robot
        self.pushed.add(robot)
        if robot not in self.switched_off:
            self.ends_before[robot][end] += 1

    def _push_over(self, task_id: str) -> None:
        robot = self.push_task.pop(task_id, None)
        if robot is not None and self.push_holder.get(robot, ("", ""))[1] == task_id:
            del self.push_holder[robot]

    # -- soak faults ------------------------------------------------------------------------------
    def _skip(self, fault: str, name: str, now: float, why: str) -> None:
        self.rec.event(now, ev.FAULT_SKIPPED, action=fault, robot=name, reason=why)

    def _freeze(self, name: str, now: float) -> None:
        """The robot's process is stopped where it stands: it has finished the previous tick
        and waits for this one. It no longer holds the lockstep clock (the world goes on
        without it, its Player session silent, so the server's watchdog stops its motors)."""
        if name in self.scheduled_down or name in self.frozen:
            self._skip("freeze", name, now, "down" if name in self.scheduled_down
                       else "already frozen")
            return
        assert self.hold_clock is not None
        pid = self.processes.pause(name, True)
        if pid is None:
            self._skip("freeze", name, now, "not running")
            return
        self.frozen.add(name)
        self.hold_clock(name, False)
        self.rec.event(now, ev.ROBOT_FREEZE, robot=name)
        self.rec.note_process(now, "stopped", name, pid)

    def _thaw(self, name: str, now: float) -> None:
        """The stopped process continues: it reads the round it was waiting for, then the
        current one; the lockstep waits for it again from this tick."""
        if name not in self.frozen:
            self._skip("thaw", name, now, "not frozen")
            return
        self._unfreeze_quietly(name)
        self.rec.event(now, ev.ROBOT_THAW, robot=name)

    def _unfreeze_quietly(self, name: str, *, resume: bool = True) -> None:
        """Forget a freeze; `resume` continues the process (else it is about to be killed,
        which works on a stopped process, so it never runs again in between)."""
        if name in self.frozen:
            self.frozen.discard(name)
            assert self.hold_clock is not None
            if resume:
                pid = self.processes.pause(name, False)
                self.hold_clock(name, True)
                self.rec.note_process(float(self.sim.time_s), "continued", name, pid)
            # killed: its session stays out of the lockstep until it closes; a new process
            # comes with a session of its own

    def _retire(self, name: str, now: float) -> None:
        """Switched off for good: the process is killed and never started again."""
        if name in self.scheduled_down:
            self._skip("retire", name, now, "already down")
            return
        self._unfreeze_quietly(name, resume=False)
        self.scheduled_down.add(name)
        pid = self.processes.kill(name)
        self.rec.event(now, ev.ROBOT_SWITCH_OFF, robot=name, permanent=True)
        self.rec.note_process(now, "switched-off", name, pid)

    def _charger_off(self, name: str, now: float) -> None:
        self.sim.set_charger_enabled(name, False)
        self.rec.event(now, ev.CHARGER_OFF, charger=name)

    def _charger_on(self, name: str, now: float) -> None:
        self.sim.set_charger_enabled(name, True)
        self.rec.event(now, ev.CHARGER_ON, charger=name)

    def _burst(self, name: str, now: float, count: int) -> None:
        """`count` tasks from the burst source introduced at this tick."""
        assert self.burst is not None
        ids = []
        for _ in range(count):
            planned = next(self.burst)
            if planned is None:
                break
            ids.append(self._announce(planned, now))
        self.rec.event(now, ev.TASK_BURST, count=len(ids), tasks=ids)

    # -- tasks and the referee ---------------------------------------------------------------
    def _introduce(self, now: float) -> None:
        while (self.next_task is not None and self.next_task.t_s <= now
               and self.next_task.t_s < self.duration_s):
            planned = self.next_task
            task_id = self._announce(planned, now)
            if self.main_task is None:
                self.main_task = task_id
                self.task_params = dict(planned.params)
            self.next_task = next(self.planned)

    def _announce(self, planned: PlannedTask, now: float) -> str:
        task_id = str(self.node.announce(self.task_spec(planned), patience_s=PATIENCE_S))
        self.rec.event(now, ev.TASK_INTRODUCED, task=task_id, task_kind=planned.kind,
                       params=planned.params, source="user")
        self.state.introduced.add(task_id)
        return task_id

    def _goal(self, now: float) -> None:
        """boxpush: move a moving goal, and re-target the watch task when it is time."""
        gw, actions, plan = self.goal_watch, self.actions, self.goal_plan
        if gw is None or actions is None or self.main_task is None:
            return
        if plan.moving and self.goal_marker is not None:
            start, _ = bp.marker_goal(self.spec, self.goal_marker)
            arena = (self.spec.arena.size_x_m, self.spec.arena.size_y_m)
            xy = plan.goal_at(start, now, arena)
            if xy != gw.goal_xy:
                gw.goal_xy = xy
                actions.put(lambda s, m=self.goal_marker, p=xy: s.set_pose(m, p[0], p[1], 0.0))
        while self.retargets and self.retargets[0][0] <= now + 1e-9:
            _, marker = self.retargets.pop(0)
            if self.state.goal_outcome is not None or self.main_task in self.state.finished:
                continue
            xy, colour = bp.marker_goal(self.spec, marker)
            old = self.main_task
            self.goal_marker = marker
            gw.goal_xy = xy
            # the user withdraws the watch task and introduces it again with the new goal
            self.node.cancel(old, f"re-targeted to {marker}")
            params = dict(self.task_params)
            params["goal_colour"] = f"#{colour:06x}"
            params["duration_s"] = max(60.0, self.duration_s - now - 5.0)
            task_id = self._announce(PlannedTask(now, "watch-box", params), now)
            self.main_task = task_id
            self.rec.event(now, ev.GOAL_MOVED, marker=marker, x=round(xy[0], 3),
                           y=round(xy[1], 3), task=task_id, replaces=old)

    def _referee(self, now: float) -> None:
        gw = self.goal_watch
        if gw is None:
            return
        if now >= self.next_progress_s - 1e-9 and gw.box_pose is not None:
            self.next_progress_s = now + BOX_PROGRESS_PERIOD_S
            bx, by, yaw = gw.box_pose
            self.rec.event(now, ev.BOX_PROGRESS, distance_m=round(gw.distance_m, 3),
                           box=[round(bx, 3), round(by, 3), round(yaw, 3)],
                           goal=[round(gw.goal_xy[0], 3), round(gw.goal_xy[1], 3)])
        st = self.state
        if st.goal_outcome is None:
            if gw.reached_at_s is not None:
                st.goal_outcome = "reached"
                self.rec.event(gw.reached_at_s, ev.GOAL_REACHED, box=gw.bg.box,
                               distance_m=round(gw.distance_m, 3), radius_m=gw.radius_m)
                log.info("goal reached at %.1f s simulated: box %.2f m from the goal",
                         gw.reached_at_s, gw.distance_m)
            elif self.main_task is not None and self.main_task in st.unachievable:
                st.goal_outcome = "unachievable"
                why = st.unachievable[self.main_task]
                self.rec.event(now, ev.GOAL_UNACHIEVABLE, task=self.main_task, reason=why)
        if self.main_task in st.finished or st.goal_outcome is not None:
            # the box reached the goal (or could not): let the last reports arrive, then stop
            if self.end_after_s is None:
                self.end_after_s = now + BOXPUSH_LINGER_S
            if now >= self.end_after_s - 1e-9:
                st.end_reason = "completed"

    # -- the end --------------------------------------------------------------------------------
    def close_open_tasks(self, end_t: float) -> None:
        """Tasks still open when the run ends fail with a reason (one terminal state each).
        On the serving thread at the last tick boundary, or by the owner after that thread
        ended early (interrupted, failed)."""
        st = self.state
        if st.closed:
            return
        st.closed = True
        why = "run ended: box at the goal" if st.goal_outcome == "reached" else "run ended"
        for task_id in self.node.open_tasks():
            self.node.cancel(task_id, why)
        for task_id in sorted(st.introduced - st.finished):
            self.rec.event(end_t, ev.TASK_OUTCOME, task=task_id, outcome=ev.FAILED,
                           reason="run ended")
            st.finished.add(task_id)
