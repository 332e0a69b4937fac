"""`python -m behaviors.host`: several robots in one process, each in a thread of its own.

    python -m behaviors.host [--log-level WARNING]

Reads commands on its standard input and writes status on its standard output
(`behaviors.host_control`): ``start NAME ARG...`` runs robot NAME with the arguments of a
`murdoch-robot` process, in a thread that does what that process does (`run_robot`: its own
Player connection, MURDOCH transport and node, events and auction log); ``kill NAME`` cuts
that robot off at once, as a killed process (`behaviors.cut`). A robot that ends or fails
is told (``exited NAME CODE``) and the others go on; a robot may be started again. End of
input, SIGINT or SIGTERM stop every robot as SIGTERM stops one `murdoch-robot`, and the
host exits. Messages and logs (each line naming its robot's thread) go to standard error;
so does a robot's ``--events -``.

Pausing one robot (SIGSTOP to its process) has no counterpart here: the robots of a host
stop and continue together.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from behaviors.__main__ import freeze_start_up, parse_args, run_robot, stop_on_signals
from behaviors.cut import Cut
from behaviors.host_control import ControlError, Kill, Start, Status, parse_command

log = logging.getLogger("murdoch-robot.host")
STOP_WAIT_S = 10.0
"""How long stopping waits for the robots' threads to end, all together."""


@dataclass
class _Robot:
    name: str
    stop: threading.Event = field(default_factory=threading.Event)
    cut: Cut = field(default_factory=Cut)
    thread: threading.Thread | None = None


class RobotThreads:
    """The robots of one host process, by name; `tell` receives every status."""

    def __init__(self, tell: Callable[[Status], None]) -> None:
        self._tell = tell
        self._lock = threading.Lock()
        self._freeze_lock = threading.Lock()
        self._robots: dict[str, _Robot] = {}

    def names(self) -> list[str]:
        with self._lock:
            return sorted(self._robots)

    def command(self, command: Start | Kill) -> None:
        if isinstance(command, Start):
            self.start(command.name, command.args)
        else:
            self.kill(command.name)

    def start(self, name: str, args: Iterable[str]) -> None:
        """Start robot `name` (one of that name still running is killed first)."""
        with self._lock:
            running = name in self._robots
        if running:
            self.kill(name)
        try:
            ns = parse_args(list(args))
        except SystemExit as exc:  # argparse said why on standard error
            self._tell(Status("exited", name, exc.code if isinstance(exc.code, int) else 2))
            return
        robot = _Robot(name)
        robot.thread = threading.Thread(target=self._run, args=(robot, ns), name=name,
                                        daemon=True)
        with self._lock:
            self._robots[name] = robot
        self._tell(Status("started", name))
        robot.thread.start()

    def kill(self, name: str) -> None:
        """Cut robot `name` off at once; its thread ends by itself, unseen."""
        with self._lock:
            robot = self._robots.pop(name, None)
        if robot is None:
            self._tell(Status("not-running", name))
            return
        robot.cut.cut()
        robot.stop.set()
        self._tell(Status("killed", name))

    def stop_all(self, wait_s: float = STOP_WAIT_S) -> None:
        """Stop every robot as SIGTERM stops one process; wait (bounded) for their threads."""
        with self._lock:
            robots = list(self._robots.values())
        for robot in robots:
            robot.stop.set()
        share = wait_s / max(len(robots), 1)
        for robot in robots:
            if robot.thread is not None:
                robot.thread.join(share)

    def _run(self, robot: _Robot, args: argparse.Namespace) -> None:
        try:
            code = run_robot(args, robot.stop, label=f"murdoch-robot {robot.name}",
                             cut=robot.cut, on_ready=self._freeze)
        except Exception:
            if not robot.cut.is_cut:
                log.exception("robot %s failed", robot.name)
            code = 1
        with self._lock:
            current = self._robots.get(robot.name) is robot
            if current:
                del self._robots[robot.name]
        if current:  # a robot killed was told so already
            self._tell(Status("exited", robot.name, code))

    def _freeze(self) -> None:
        with self._freeze_lock:
            freeze_start_up()


def serve_commands(lines: Iterable[str], robots: RobotThreads,
                   tell: Callable[[Status], None]) -> None:
    """Act on each command line until the input ends."""
    for line in lines:
        if not line.strip():
            continue
        try:
            command = parse_command(line)
        except ControlError as exc:
            tell(Status("refused", text=str(exc)))
            continue
        robots.command(command)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m behaviors.host",
                                description="Run several robots, each in a thread, on the "
                                            "commands of standard input.")
    p.add_argument("--log-level", default="WARNING", help="logging level (default WARNING)")
    args = p.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s %(threadName)s %(name)s %(levelname)s %(message)s")
    status_out = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1, encoding="utf-8")
    sys.stdout = sys.stderr  # status lines only on the status channel
    status_lock = threading.Lock()

    def tell(status: Status) -> None:
        # OSError, ValueError: nobody reads the status any more
        with status_lock, contextlib.suppress(OSError, ValueError):
            status_out.write(status.line() + "\n")

    stop = stop_on_signals()
    robots = RobotThreads(tell)

    def control() -> None:
        try:
            serve_commands(sys.stdin, robots, tell)
        finally:
            stop.set()  # end of input: the run is over

    threading.Thread(target=control, name="control", daemon=True).start()
    while not stop.wait(0.5):
        pass
    robots.stop_all()
    return 0


if __name__ == "__main__":
    sys.exit(main())
