"""The box-pushing experiment: a watcher leads two pushers to get a box to a goal marker.

The user introduces one task (watch the box to the goal, `task_source.boxpush_task`); the
watcher auctions the pushes. The referee (`BoxpushReferee`) watches the box's ground-truth
distance to the goal and ends the run when it has arrived (or cannot), switches pushers off
and on (`--switch-off`, `--switch-on`: moved out of the way, placed back behind the other end
of the box), moves the goal (`--goal-velocity`) and re-targets the watch task
(`--retarget`). With `--rounds` (0 under `murdoch soak`) the run goes on after the box
arrives: the round is recorded (`box_round`), the box and the robots go back to their start
poses and the watch task is introduced again, until the rounds or the run's span are used up.
Its summary section is ``goal``; its plot the box's distance to the goal.
"""

from __future__ import annotations

import functools
import logging
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from experiments import boxpush as bp
from experiments import events as ev
from experiments.plugin import (
    ExperimentBase,
    Fault,
    Option,
    OptionError,
    Referee,
    RunHandle,
    RunOptions,
    Sampler,
    Supports,
    Verdict,
    labels,
    robot_at_time,
)
from experiments.task_source import PlannedTask, boxpush_task
from worlds import WorldSpec

log = logging.getLogger("murdoch.run")

BOXPUSH_LINGER_S = 3.0
"""After the box's fate is decided, the run goes on this long for the last reports."""
BOX_PROGRESS_PERIOD_S = 1.0
"""How often the box's distance to the goal goes into the events."""


def place(sim: Any, name: str, pose: tuple[float, float, float],
          odometry: tuple[float, float, float] | None = None) -> None:
    """Teleport a robot (on the serving thread) and leave it standing still."""
    sim.set_velocity(name, 0.0, 0.0)
    sim.set_pose(name, *pose)
    if odometry is not None:
        sim.set_odometry(name, *odometry)


def _move_marker(sim: Any, marker: str, xy: tuple[float, float]) -> None:
    sim.set_pose(marker, xy[0], xy[1], 0.0)


OPTIONS = (
    Option("--switch-off", "switch a pusher off (process stopped, robot moved out of the "
           "way): ROBOT@TIME, e.g. p1@60s.", type=robot_at_time, multiple=True,
           metavar="ROBOT@TIME"),
    Option("--switch-on", "switch a pusher back on behind the other end of the box: "
           "ROBOT@TIME.", type=robot_at_time, multiple=True, metavar="ROBOT@TIME"),
    Option("--goal-radius", "the box has arrived when its centre is this close to the goal "
           "marker (metres, default 2.5).", type=float),
    Option("--goal-velocity", "the goal marker moves at VX,VY metres per second from the "
           "start (e.g. 0,-0.01), stopping short of the walls.", metavar="VX,VY"),
    Option("--retarget", "give the watch task another goal marker of the world at a time: "
           "MARKER@TIME, e.g. goal2@60s.", type=robot_at_time, multiple=True,
           metavar="MARKER@TIME"),
    Option("--rounds", "push the box to the goal N times: each time it arrives, the box and "
           "the robots go back to their start and the watch task is introduced again; 0 = "
           "until the run's span ends (default 1; murdoch soak: 0).", type=int, metavar="N"),
)


def switches(options: RunOptions, which: str) -> tuple[tuple[str, float], ...]:
    """The (robot, t) entries of --switch-off (`which` 'switch_off') or --switch-on."""
    return tuple(options.get(which, ()))


def goal_plan(options: RunOptions) -> bp.GoalPlan:
    """The goal's plan as `Boxpush.check` made it (the default plan before)."""
    plan = options.get("goal_plan")
    return plan if isinstance(plan, bp.GoalPlan) else bp.GoalPlan()


def resolve_switches(spec: WorldSpec, options: RunOptions) -> RunOptions:
    """Switch-offs and -ons with the robots' full names ('p1' -> 'pusher1')."""
    names = [r.name for r in spec.robots]
    own = dict(options.own)
    for which in ("switch_off", "switch_on"):
        try:
            own[which] = tuple((bp.resolve_robot(r, names), t)
                               for r, t in switches(options, which))
        except ValueError as exc:
            raise OptionError(f"--{which.replace('_', '-')}", str(exc)) from exc
    return replace(options, own=own)


def rounds(options: RunOptions) -> int:
    """How many times the box is to reach the goal (0: until the run's span ends)."""
    return int(options.get("rounds", 1))


def _goal_plan(options: RunOptions) -> bp.GoalPlan:
    velocity = options.get("goal_velocity")
    try:
        v = bp.parse_velocity(velocity) if velocity else (0.0, 0.0)
    except ValueError as exc:
        raise OptionError("--goal-velocity", str(exc)) from exc
    moves = tuple(sorted((t, m) for m, t in options.get("retarget", ())))
    return bp.GoalPlan(v, moves)


class BoxpushReferee:
    """The goal watch, the pushers' switch-offs and -ons and the goal's moves, run by the
    runner's loop on the serving thread."""

    def __init__(self, spec: WorldSpec, options: RunOptions) -> None:
        self.spec = spec
        self.duration_s = options.duration_s
        self.goal_watch = bp.GoalWatch(bp.box_goal(spec),
                                       options.get("goal_radius") or bp.GOAL_RADIUS_M,
                                       tuple(r.name for r in spec.robots if r.mobile))
        self.actions = bp.SimActions()
        self.samplers: tuple[Sampler, ...] = ((0.5, self.goal_watch.sample),
                                              (0.0, self.actions.apply))
        self.goal_plan: bp.GoalPlan = goal_plan(options)
        self.retargets = sorted(self.goal_plan.retargets)
        self.goal_marker: str | None = self.goal_watch.bg.goal
        self.next_progress_s = 0.0
        self.end_after_s: float | None = None
        self.rounds = rounds(options)
        self.round = 1
        self.arrivals = 0
        self.next_round_s: float | None = None
        self.round_over_why = ""
        self.switched_off: dict[str, float] = {}
        # which end each pusher pushes now and pushed before; switch-ons waiting
        self.task_kind: dict[str, str] = {}
        self.push_holder: dict[str, tuple[str, str]] = {}  # robot -> (end, task)
        self.push_task: dict[str, str] = {}  # task -> robot
        self.pushed: set[str] = set()
        self.ends_before: dict[str, Counter[str]] = defaultdict(Counter)
        self.worked_end: dict[str, str] = {}
        self.pending_on: dict[str, float] = {}
        # the watch task (the task source's, or the latest introduced in its place), the
        # parameters it was introduced with, and the box's fate: reached, unachievable or None
        self.main_task: str | None = None
        self.task_params: dict[str, Any] = {}
        self.goal_outcome: str | None = None
        self._loop: RunHandle | None = None

    @property
    def loop(self) -> RunHandle:
        assert self._loop is not None, "bind() first"
        return self._loop

    def bind(self, loop: RunHandle) -> None:
        self._loop = loop

    def fault_actions(self) -> Mapping[str, Callable[[str, float], None]]:
        return {"switch-off": self._switch_off, "switch-on": self._switch_on}

    # -- auctions
    def on_announce(self, task_id: str, name: str) -> None:
        self.task_kind.setdefault(task_id, name)

    def on_award(self, task_id: str, robot: str) -> None:
        end = bp.PUSH_ENDS.get(self.task_kind.get(task_id, ""))
        if end is None:
            return
        self.push_holder[robot] = (end, task_id)
        self.push_task[task_id] = robot
        self.pushed.add(robot)
        if robot not in self.switched_off:
            self.ends_before[robot][end] += 1

    def on_task_over(self, task_id: str) -> None:
        robot = self.push_task.pop(task_id, None)
        if robot is not None and self.push_holder.get(robot, ("", ""))[1] == task_id:
            del self.push_holder[robot]

    # -- the tick
    def before_tasks(self, now: float) -> None:
        if self.pending_on:
            self._pending_switch_ons(now)

    def after_tasks(self, now: float) -> None:
        first = self.loop.first_task() if self.main_task is None else None
        if first is not None:
            self.main_task, self.task_params = first[0], dict(first[1].params)
        self._goal(now)
        self._referee(now)

    # -- switching pushers off and on
    def _switch_off(self, name: str, now: float) -> None:
        loop, gw = self.loop, self.goal_watch
        loop.stop_robot(name, now)
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
        spot = bp.park_pose(self.spec, loop.robots().index(name))
        self.actions.put(functools.partial(place, name=name, pose=spot))
        loop.record(now, ev.ROBOT_SWITCH_OFF, robot=name, side_m=round(side, 3),
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
        gw = self.goal_watch
        self.switched_off.pop(name, None)
        box_pose = gw.box_pose if gw.box_pose is not None else self._box_start()
        offset = bp.end_offset(box_pose, gw.goal_xy, end, gw.bg)
        pose = bp.return_pose(box_pose, gw.goal_xy, offset, gw.bg)
        start = next(r.pose for r in self.spec.robots if r.name == name)
        odo = bp.odometry_at((start[0], start[1], start[2]), pose)
        # placed by hand and told where it is: odometry stays in the shared frame
        self.actions.put(functools.partial(place, name=name, pose=pose, odometry=odo))
        self.loop.start_robot(name, now)
        self.loop.record(now, ev.ROBOT_SWITCH_ON, robot=name, x=round(pose[0], 3),
                         y=round(pose[1], 3), yaw=round(pose[2], 3), end=end,
                         other_at_old_end=other_ready, asked_t=round(asked_at, 3))

    # -- the goal
    def _goal(self, now: float) -> None:
        """Move a moving goal, and re-target the watch task when it is time."""
        loop, gw, plan = self.loop, self.goal_watch, self.goal_plan
        if self.main_task is None:
            return
        if plan.moving and self.goal_marker is not None:
            start, _ = bp.marker_goal(self.spec, self.goal_marker)
            arena = (self.spec.arena.size_x_m, self.spec.arena.size_y_m)
            xy = plan.goal_at(start, now, arena)
            if xy != gw.goal_xy:
                gw.goal_xy = xy
                self.actions.put(functools.partial(_move_marker, marker=self.goal_marker, xy=xy))
        while self.retargets and self.retargets[0][0] <= now + 1e-9:
            _, marker = self.retargets.pop(0)
            if self.goal_outcome is not None or loop.task_ended(self.main_task):
                continue
            xy, colour = bp.marker_goal(self.spec, marker)
            old = self.main_task
            self.goal_marker = marker
            gw.goal_xy = xy
            # the user withdraws the watch task and introduces it again with the new goal
            loop.withdraw(old, f"re-targeted to {marker}")
            params = dict(self.task_params)
            params["goal_colour"] = f"#{colour:06x}"
            params["duration_s"] = max(60.0, self.duration_s - now - 5.0)
            task_id = loop.announce(PlannedTask(now, "watch-box", params), now)
            self.main_task = task_id
            loop.record(now, ev.GOAL_MOVED, marker=marker, x=round(xy[0], 3),
                        y=round(xy[1], 3), task=task_id, replaces=old)

    def _referee(self, now: float) -> None:
        loop, gw = self.loop, self.goal_watch
        if now >= self.next_progress_s - 1e-9 and gw.box_pose is not None:
            self.next_progress_s = now + BOX_PROGRESS_PERIOD_S
            bx, by, yaw = gw.box_pose
            loop.record(now, ev.BOX_PROGRESS, distance_m=round(gw.distance_m, 3),
                        box=[round(bx, 3), round(by, 3), round(yaw, 3)],
                        goal=[round(gw.goal_xy[0], 3), round(gw.goal_xy[1], 3)])
        if self.next_round_s is not None:
            if now >= self.next_round_s - 1e-9:
                self._next_round(now)
            return
        more = self.rounds == 0 or self.round < self.rounds
        main = self.main_task
        given_up = loop.unachievable(main) if main is not None else None
        ended = main is not None and loop.task_ended(main)
        if self.goal_outcome is None:
            if gw.reached_at_s is not None:
                if more:
                    # not the last round: the next one starts once the last reports are in
                    self._round_over(now, "reached")
                else:
                    self.goal_outcome = "reached"
                    loop.set_closing_reason("run ended: box at the goal")
                self.arrivals += 1
                loop.record(gw.reached_at_s, ev.GOAL_REACHED, box=gw.bg.box,
                            distance_m=round(gw.distance_m, 3), radius_m=gw.radius_m)
                log.info("goal reached at %.1f s simulated: box %.2f m from the goal",
                         gw.reached_at_s, gw.distance_m)
            elif more and (given_up is not None or ended):
                # the watch task ended without the box (e.g. a pusher gone for good): the
                # round is over all the same
                self._round_over(now, given_up if given_up is not None
                                 else "the watch task ended")
            elif given_up is not None:
                self.goal_outcome = "unachievable"
                loop.record(now, ev.GOAL_UNACHIEVABLE, task=main, reason=given_up)
        if self.next_round_s is not None:
            return
        if ended or self.goal_outcome is not None:
            # the box reached the goal (or could not): let the last reports arrive, then stop
            if self.end_after_s is None:
                self.end_after_s = now + BOXPUSH_LINGER_S
            if now >= self.end_after_s - 1e-9:
                loop.end("completed")

    # -- rounds
    def _round_over(self, now: float, why: str) -> None:
        self.next_round_s = now + BOXPUSH_LINGER_S
        self.round_over_why = why

    def _next_round(self, now: float) -> None:
        """The round is over (the box arrived, or the watch task ended without it) and the
        run goes on: the user withdraws the watch task (if still open), the stage hands put
        the box and the robots back at their start poses (robots that are down are parked),
        and the watch task is introduced again."""
        loop = self.loop
        self.next_round_s = None
        self.round += 1
        old = self.main_task
        if old is not None and not loop.task_ended(old):
            why = self.round_over_why
            loop.withdraw(old, "round over: " + ("box at the goal" if why == "reached"
                                                 else why))
        self.actions.put(functools.partial(self._reset_stage, down=loop.down(),
                                           names=loop.robots()))
        params = dict(self.task_params)
        if self.goal_marker is not None and self.goal_marker != self.goal_watch.bg.goal:
            params["goal_colour"] = f"#{bp.marker_goal(self.spec, self.goal_marker)[1]:06x}"
        params["duration_s"] = max(60.0, self.duration_s - now - 5.0)
        task_id = loop.announce(PlannedTask(now, "watch-box", params), now)
        self.main_task = task_id
        loop.record(now, ev.BOX_ROUND, round=self.round, task=task_id, replaces=old,
                    after=self.round_over_why)
        log.info("round %d at %.1f s simulated: box back at its start", self.round, now)

    def _box_start(self) -> tuple[float, float, float]:
        box = next(b for b in self.spec.boxes if b.name == self.goal_watch.bg.box)
        return box.pose[0], box.pose[1], box.pose[2]

    def _reset_stage(self, sim: Any, down: frozenset[str], names: tuple[str, ...]) -> None:
        """(serving thread, between steps) The box and the robots at their start poses
        (robots `down` when the round ended parked out of the way); the goal watch forgets
        the arrival (its next sample sees the box back at the start)."""
        gw = self.goal_watch
        sim.set_pose(gw.bg.box, *self._box_start())
        for robot in self.spec.robots:
            if not robot.mobile or robot.name in self.switched_off:
                continue
            start = (robot.pose[0], robot.pose[1], robot.pose[2])
            # a robot that is down (killed, switched off for good) is parked out of the way
            pose = bp.park_pose(self.spec, names.index(robot.name)) if (
                robot.name in down and robot.name in names) else start
            place(sim, robot.name, pose, odometry=bp.odometry_at(start, pose))
        gw.reached_at_s = None


# -------------------------------------------------------------------- the summary section
def push_phases(events: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """Pushes (awards) per end per pusher, before the first switch-off, while alone (until
    the next switch-on) and after it; with one switch-off and -on, whether the returning
    pusher's main end changed (`role_swap`)."""
    evs = list(events)
    kind_of = {str(e["task"]): str(e["task_kind"]) for e in evs
               if e["kind"] == ev.TASK_INTRODUCED}
    off = next((e for e in evs if e["kind"] == ev.ROBOT_SWITCH_OFF), None)
    on = next((e for e in evs if e["kind"] == ev.ROBOT_SWITCH_ON
               and (off is None or float(e["t"]) >= float(off["t"]))), None)
    t_off = float(off["t"]) if off is not None else None
    t_on = float(on["t"]) if on is not None else None

    def phase(t: float) -> str:
        if t_off is None or t < t_off:
            return "before" if t_off is not None else "run"
        if t_on is None or t < t_on:
            return "alone"
        return "after"

    pushes: dict[str, dict[str, Counter[str]]] = defaultdict(lambda: defaultdict(Counter))
    for e in evs:
        if e["kind"] == ev.AWARD:
            end = bp.PUSH_ENDS.get(kind_of.get(str(e["task"]), ""))
            if end is not None:
                pushes[phase(float(e["t"]))][str(e["robot"])][end] += 1
    out: dict[str, Any] = {
        "phases": {p: {r: dict(sorted(c.items())) for r, c in sorted(by.items())}
                   for p, by in pushes.items()},
        "switch_off_t_s": t_off, "switch_on_t_s": t_on, "role_swap": None,
    }
    if off is not None and on is not None and str(on["robot"]) == str(off["robot"]):
        robot = str(off["robot"])

        def main_end(p: str) -> str | None:
            c = pushes.get(p, {}).get(robot, Counter())
            ranked = c.most_common(2)
            if not ranked or (len(ranked) > 1 and ranked[0][1] == ranked[1][1]):
                return None
            return ranked[0][0]

        before, after = main_end("before"), main_end("after")
        out["role_swap"] = {"robot": robot, "end_before": before, "end_after": after,
                            "swapped": before is not None and after is not None
                            and before != after}
    return out


def box_track(events: Iterable[Mapping[str, Any]]) -> list[tuple[float, float]]:
    """(t, the box's distance to the goal) from the referee's samples."""
    return [(float(e["t"]), float(e["distance_m"])) for e in events
            if e["kind"] == ev.BOX_PROGRESS]


def goal_section(evs: list[Mapping[str, Any]]) -> dict[str, Any]:
    """summary.json's ``goal``: reached or not, switch-offs and -ons, goal moves, pushes."""
    kinds = Counter(str(e["kind"]) for e in evs)
    reached = next((e for e in evs if e["kind"] == ev.GOAL_REACHED), None)
    unachievable = next((e for e in evs if e["kind"] == ev.GOAL_UNACHIEVABLE), None)
    track = box_track(evs)
    return {
        "reached": reached is not None,
        "reached_t_s": round(float(reached["t"]), 3) if reached is not None else None,
        "box_distance_m": reached.get("distance_m") if reached is not None else None,
        "unachievable": unachievable is not None,
        "unachievable_reason": unachievable.get("reason") if unachievable else None,
        "switch_offs": kinds[ev.ROBOT_SWITCH_OFF],
        "switch_ons": kinds[ev.ROBOT_SWITCH_ON],
        "goal_moves": kinds[ev.GOAL_MOVED],
        "rounds": 1 + kinds[ev.BOX_ROUND],
        "arrivals": kinds[ev.GOAL_REACHED],
        "final_distance_m": track[-1][1] if track else None,
        "pushes": push_phases(evs),
    }


# -------------------------------------------------------------------------- the experiment
@dataclass(frozen=True)
class Boxpush(ExperimentBase):
    def check(self, spec: WorldSpec, options: RunOptions) -> RunOptions:
        options = resolve_switches(spec, options)
        plan = _goal_plan(options)
        for _, marker in plan.retargets:
            try:
                bp.marker_goal(spec, marker)
            except ValueError as exc:
                raise OptionError("--retarget", str(exc)) from exc
        if rounds(options) < 0:
            raise OptionError("--rounds", f"expected 0 or more rounds, found {rounds(options)}")
        return replace(options, own={**options.own, "goal_plan": plan})

    def config(self, options: RunOptions) -> dict[str, Any]:
        plan = goal_plan(options)
        return {
            "switch_offs": labels(switches(options, "switch_off")),
            "switch_ons": labels(switches(options, "switch_on")),
            "goal_radius_m": options.get("goal_radius") or bp.GOAL_RADIUS_M,
            "goal_velocity_mps": list(plan.velocity_mps),
            "retargets": [f"{m}@{t:g}s" for t, m in plan.retargets],
            **({"rounds": rounds(options)} if rounds(options) != 1 else {}),
        }

    def tasks(self, spec: WorldSpec, options: RunOptions) -> Iterator[PlannedTask | None]:
        return iter([boxpush_task(spec, options.duration_s), None])

    def referee(self, spec: WorldSpec, options: RunOptions) -> Referee:
        return BoxpushReferee(spec, options)

    def faults(self, options: RunOptions) -> list[Fault]:
        return ([Fault(t, "switch-off", r) for r, t in switches(options, "switch_off")]
                + [Fault(t, "switch-on", r) for r, t in switches(options, "switch_on")])

    def summary_sections(self, events: list[Mapping[str, Any]]) -> dict[str, Any]:
        return {"goal": goal_section(events)}

    def plots(self, events: list[Mapping[str, Any]], out_dir: Path) -> list[Path]:
        from experiments.plots import BOX_PLOT, plot_box_distance, save

        if not any(e["kind"] == ev.BOX_PROGRESS for e in events):
            return []
        return [save(plot_box_distance(events), out_dir / BOX_PLOT)]

    def end_lines(self, referee: Referee) -> list[str]:
        if not isinstance(referee, BoxpushReferee):
            return []
        gw = referee.goal_watch
        if referee.rounds != 1:
            return [f"the box reached the goal {referee.arrivals} times in {referee.round} "
                    f"rounds"]
        if referee.goal_outcome != "reached":
            return []
        return [f"goal reached at {gw.reached_at_s:.1f} s simulated: "
                f"box {gw.distance_m:.2f} m from the goal"]

    def verdict(self, summary: Mapping[str, Any]) -> Verdict | None:
        goal = summary.get("goal")
        if goal is not None and goal.get("unachievable"):
            return Verdict(4, f"error: the box cannot be pushed to the goal: "
                              f"{goal.get('unachievable_reason')}")
        return None


BOXPUSH = Boxpush(
    "boxpush", "boxpush", steps=(
        "murdoch run boxpush --until 10m --switch-off p1@40s --switch-on p1@150s",
        "murdoch run boxpush --meshcat           # watch it live in the browser",
    ),
    options=OPTIONS,
    task_kinds=("watch-box",),
    supports=Supports(soak=True, compare=True, sub_tasks=True, soak_options=(("rounds", 0),)),
)
