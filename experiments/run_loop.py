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
4. lets the experiment's referee act (`experiments.plugin.Referee`: boxpush's pending
   switch-ons), introduces due tasks, lets the referee act again (boxpush's goal moves and
   goal watch), ends the run when its end is decided;
5. steps its MURDOCH node (auctions, awards, renewals, reintroduction with backoff).

Nothing here looks at the wall clock except the bound on waiting for declared datagrams,
which can only end the run with an error. The main thread does the wall-clock work
(progress display, memory samples into processes.jsonl, signals).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

from experiments import events as ev
from experiments.group_coordinator import GroupCoordinator
from experiments.log_writes import FolderWrites
from experiments.observe import JsonlTail, robot_event_to_run_events
from experiments.plugin import Fault, NoReferee, Referee
from experiments.task_source import PlannedTask

log = logging.getLogger("murdoch.run")

PATIENCE_S = 300.0
DEATH_CHECK_TICKS = 10
"""How often (in ticks) the runner looks for robot processes that died by themselves."""

__all__ = ["Fault", "RobotProcesses", "RunLoop", "RunState"]  # Fault: experiments.plugin


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
    closing_reason: str = "run ended"
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
        referee: Referee | None = None,
        mobile: frozenset[str] = frozenset(),
        hold_clock: Callable[[str, bool], None] | None = None,
        burst: Iterator[PlannedTask | None] | None = None,
        whole_groups: bool = False,
    ) -> None:
        self.rec = rec
        self.sim = sim
        self.node = node
        self.transport = transport
        self.processes = processes
        self.tails = dict(sorted(tails.items()))
        # which of the tails' files were written to (set when the robots start)
        self.log_writes: FolderWrites | None = None
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
        self.mobile = mobile
        self.interval_s = float(sim.interval_s)
        self.state = RunState()
        self.announced_at: dict[str, float] = {}
        self.first: tuple[str, PlannedTask] | None = None
        self.busy_killed: list[str] = []
        self.scheduled_down: set[str] = set()
        self.hold_clock = hold_clock
        self.burst = burst
        self.frozen: set[str] = set()
        self.busy_frozen: list[str] = []
        self.episodes: list[str | None] = []
        self.referee: Referee = referee if referee is not None else NoReferee()
        self._actions: dict[str, Callable[[str, float], None]] = {
            "kill": self._kill, "restart": self._restart, "freeze": self._freeze,
            "thaw": self._thaw, "retire": self._retire, "charger-off": self._charger_off,
            "charger-on": self._charger_on, **self.referee.fault_actions()}
        self.referee.bind(self)
        self.groups = GroupCoordinator(rec=rec, node=node, sim=sim, mobile=mobile,
                                       introduced=self.state.introduced,
                                       finished=self.state.finished, patience_s=PATIENCE_S,
                                       whole=whole_groups)

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
        self.referee.before_tasks(now)
        self._introduce(now)
        self.groups.step(now, self.scheduled_down | self.frozen)
        self.referee.after_tasks(now)
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
        # only the logs written since the last tick are read (all of them when that cannot
        # be told), in the same order as ever
        written = self.log_writes.written() if self.log_writes is not None else None
        if written is not None and not written:
            return
        for events, auctions in self.tails.values():
            if written is None or events.path.name in written:
                for d in events.read_new():
                    for e in robot_event_to_run_events(d):
                        self.rec.event(e.pop("t"), e.pop("kind"), **e)
            if written is None or auctions.path.name in written:
                for d in auctions.read_new():
                    if "time_s" in d and "kind" in d:
                        self.on_auction_event(d)

    def on_auction_event(self, d: dict[str, Any]) -> None:
        """An auctioneer's event (the runner's own or a robot's) as run events."""
        kind, task_id, t = d.get("kind"), str(d.get("task_id")), float(d["time_s"])
        st = self.state
        if kind == "announce":
            self.referee.on_announce(task_id, str(d.get("name", "")))
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
                           bid=d.get("score"), latency_s=round(latency, 4),
                           **({"seat": d["seat"]} if "seat" in d else {}))
            self.referee.on_award(task_id, str(d.get("winner")))
        elif kind == "reallocation":
            self.referee.on_task_over(task_id)
            self.rec.event(t, ev.REALLOCATION, task=task_id, from_robot=d.get("winner"),
                           reason=d.get("reason", ""))
        elif kind in ("decline", "expired"):
            # a bidder refused an award (busy, bid expired) or gave up waiting for one: never
            # silent (docs/murdoch.md, late awards)
            self.rec.event(t, ev.BID_DECLINED if kind == "decline" else ev.BID_EXPIRED,
                           task=task_id, robot=d.get("agent"),
                           **({"reason": d["reason"]} if "reason" in d else {}))
        elif kind == "outcome" and task_id not in st.finished:
            self.referee.on_task_over(task_id)
            why = str(d.get("reason", ""))
            if d.get("status") == "unachievable" or why.startswith("unachievable"):
                st.unachievable[task_id] = why or "unachievable"
            self.rec.event(t, ev.TASK_OUTCOME, task=task_id, outcome=d.get("status"),
                           robot=d.get("winner"), reason=d.get("reason", ""))
            st.finished.add(task_id)
            self.groups.on_outcome(task_id, str(d.get("status")), t)

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
                self._actions[fault.action](name, now)

    def _kill(self, name: str, now: float) -> None:
        self._take_down(name, now, "killed")
        self.rec.event(now, ev.ROBOT_FAILURE, robot=name, reason="killed")

    def _take_down(self, name: str, now: float, note: str) -> None:
        """The robot's process killed at once (continued first if frozen: it never runs
        again in between); it is down until started again."""
        self._unfreeze_quietly(name, resume=False)
        self.scheduled_down.add(name)
        pid = self.processes.kill(name)
        self.rec.note_process(now, note, name, pid)

    def _restart(self, name: str, now: float) -> None:
        self.start_process(name, now)
        self.rec.event(now, ev.ROBOT_RESTART, robot=name)

    def start_process(self, name: str, now: float) -> int:
        """Start the robot's process (replacing one still running); the lockstep expects it
        from the next tick."""
        self._unfreeze_quietly(name, resume=False)
        self.processes.kill(name)  # a process still running is replaced
        pid = self.processes.start(name)
        self.rec.note_process(now, "started", name, pid)
        self.scheduled_down.discard(name)
        if self.expect is not None:
            self.expect(name)
        return pid

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
        self._take_down(name, now, "switched-off")
        self.rec.event(now, ev.ROBOT_SWITCH_OFF, robot=name, permanent=True)

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
            ids.append(self.announce(planned, now))
        self.rec.event(now, ev.TASK_BURST, count=len(ids), tasks=ids)

    # -- tasks and the referee ---------------------------------------------------------------
    def _introduce(self, now: float) -> None:
        while (self.next_task is not None and self.next_task.t_s <= now
               and self.next_task.t_s < self.duration_s):
            planned = self.next_task
            task_id = self.announce(planned, now)
            if self.first is None:
                self.first = (task_id, planned)
            self.next_task = next(self.planned)

    def announce(self, planned: PlannedTask, now: float) -> str:
        """Introduce a task as the user (reintroduced with backoff while unachievable); a
        group task goes to the group coordinator."""
        if self.groups.handles(planned.kind):
            return self.groups.introduce(planned, now)
        task_id = str(self.node.announce(self.task_spec(planned), patience_s=PATIENCE_S))
        self.rec.event(now, ev.TASK_INTRODUCED, task=task_id, task_kind=planned.kind,
                       params=planned.params, source="user")
        self.state.introduced.add(task_id)
        return task_id

    # -- the referee's handle (`experiments.plugin.RunHandle` says what each one does) ------
    def withdraw(self, task_id: str, reason: str) -> None:
        self.node.cancel(task_id, reason)

    def first_task(self) -> tuple[str, PlannedTask] | None:
        return self.first

    def task_ended(self, task_id: str) -> bool:
        return task_id in self.state.finished

    def unachievable(self, task_id: str) -> str | None:
        return self.state.unachievable.get(task_id)

    def robots(self) -> tuple[str, ...]:
        return tuple(sorted(self.processes.names()))

    def down(self) -> frozenset[str]:
        return frozenset(self.scheduled_down)

    def stop_robot(self, name: str, now: float) -> None:
        self._take_down(name, now, "switched-off")

    def start_robot(self, name: str, now: float) -> None:
        self.start_process(name, now)

    def record(self, t_s: float, kind: str, **fields: Any) -> None:
        self.rec.event(t_s, kind, **fields)

    def end(self, reason: str) -> None:
        if self.state.end_reason is None:
            self.state.end_reason = reason

    def set_closing_reason(self, reason: str) -> None:
        self.state.closing_reason = reason

    # -- the end --------------------------------------------------------------------------------
    def close_open_tasks(self, end_t: float) -> None:
        """Tasks still open when the run ends fail with a reason (one terminal state each).
        On the serving thread at the last tick boundary, or by the owner after that thread
        ended early (interrupted, failed)."""
        st = self.state
        if st.closed:
            return
        st.closed = True
        for task_id in self.node.open_tasks():
            self.node.cancel(task_id, st.closing_reason)
        for task_id in sorted(st.introduced - st.finished):
            self.rec.event(end_t, ev.TASK_OUTCOME, task=task_id, outcome=ev.FAILED,
                           reason="run ended")
            st.finished.add(task_id)
