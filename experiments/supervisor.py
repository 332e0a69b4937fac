"""The processes of a run: described as data, started, stopped and watched.

A run's processes are written down like a launch file (`ProcessSpec`: name, command,
arguments, restart policy) and go into the run's config.json. `RobotSupervisor` starts them
from those descriptions, kills and pauses them on the fault schedule's word and notices the
ones that ended by themselves (what `experiments.run_loop.RobotProcesses` asks of it).
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from experiments.robot_launcher import LauncherGone, RobotLauncher
from player_server.children import ChildProcess, end_child

log = logging.getLogger("murdoch.run")

RESTART_POLICIES = ("never", "on-schedule")
"""never: a process that ends stays down; on-schedule: started again only when the run's
fault schedule says so (a restart or a switch-on); nothing restarts by itself."""


@dataclass(frozen=True)
class ProcessSpec:
    """One process of a run. In `args`, ``{port}`` (the Player port of the process's
    endpoint) and ``{instance}`` (how many times it was started before) are filled in at
    each start. `launch` is a command prefix that places the process elsewhere: empty runs
    it here; ``ip netns exec NS`` runs it in network namespace NS; ``ssh HOST`` on another
    host (which needs the same installation and run directory paths, see
    docs/experiments.md)."""

    name: str
    command: tuple[str, ...]
    args: tuple[str, ...]
    restart: str = "on-schedule"
    launch: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.restart not in RESTART_POLICIES:
            raise ValueError(f"process {self.name}: restart must be one of "
                             f"{RESTART_POLICIES}, found {self.restart!r}")

    def argv(self, *, port: int, instance: int) -> list[str]:
        return [*self.launch, *self.command, *self.arguments(port=port, instance=instance)]

    def arguments(self, *, port: int, instance: int) -> list[str]:
        """`args` filled in (what a host of several robots is given for this one)."""
        values = {"port": str(port), "instance": str(instance)}
        return [a.format_map(values) for a in self.args]

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "command": list(self.command), "args": list(self.args),
                "restart": self.restart, "launch": list(self.launch)}


def robot_command() -> list[str]:
    """The `murdoch-robot` entry point next to this interpreter (or its module)."""
    exe = Path(sys.executable).parent / "murdoch-robot"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "behaviors"]


@dataclass(frozen=True)
class BusPlace:
    """How a robot process reaches the run: the Player server's address and the team bus
    (multicast on this host's loopback, or Zenoh through the runner's hub)."""

    server_host: str = "127.0.0.1"
    mcast_port: int = 0
    zenoh_endpoint: str = ""
    """Non-empty: the robots join MURDOCH over Zenoh through this hub endpoint."""

    def args(self) -> list[str]:
        out = ["-h", self.server_host]
        if self.zenoh_endpoint:
            out += ["--transport", "zenoh", "--zenoh-endpoint", self.zenoh_endpoint]
            if not self.zenoh_endpoint.startswith("tcp/127.0.0.1:"):
                out.append("--zenoh-allow-remote")
        else:
            out += ["--mcast-port", str(self.mcast_port)]
        return out


def robot_process(name: str, *, world: str, bus: BusPlace, seed: int, logs: Path,
                  metric_terms: tuple[str, ...], lockstep: bool,
                  read_timeout_s: float, allocator: str = "murdoch",
                  launch: tuple[str, ...] = (), refine: bool = False) -> ProcessSpec:
    """The `murdoch-robot` process that drives the endpoint `name` (placed by `launch`; with
    `allocator` other than MURDOCH, its command line names it, and `refine` adds
    `--refine`; MURDOCH's stays as it always was)."""
    args = ["-p", "{port}", "--name", name, "--world", world, *bus.args(),
            "--seed", str(seed), "--instance", "{instance}",
            "--events", str(logs / f"{name}.events.jsonl"),
            "--auction-log", str(logs / f"{name}.auction.jsonl")]
    if metric_terms:
        args += ["--metric", ",".join(metric_terms)]
    if allocator != "murdoch":
        args += ["--allocator", allocator]
    if refine:
        args += ["--refine"]
    if lockstep:
        # in lockstep a robot waits for the slowest of the team (one starting up on a
        # loaded machine, say): the runner's own stall limit ends a run that truly hangs
        args += ["--lockstep-bus", "--request-timeout", "120",
                 "--read-timeout", str(int(read_timeout_s))]
    return ProcessSpec(name, tuple(robot_command()), tuple(args), launch=launch)


@dataclass
class RobotProcess:
    name: str
    port: int
    proc: ChildProcess | None = None
    log_file: IO[bytes] | None = None


def start_robot(rp: RobotProcess, args: list[str], log_path: Path, nice: int = 0,
                env: dict[str, str] | None = None) -> None:
    if rp.log_file is None:
        rp.log_file = log_path.open("ab")
    rp.proc = subprocess.Popen(args, stdout=rp.log_file, stderr=subprocess.STDOUT,
                               stdin=subprocess.DEVNULL, env=env)
    _lower_priority(rp, nice)


def _lower_priority(rp: RobotProcess, nice: int) -> None:
    if nice > 0 and rp.proc is not None:
        # a lower priority than the simulator's serving thread, which every robot waits on
        try:
            os.setpriority(os.PRIO_PROCESS, rp.proc.pid, nice)
        except OSError as exc:  # the process may have gone already
            log.warning("could not lower the priority of robot %s: %s", rp.name, exc)


def stop_robot(rp: RobotProcess, *, kill: bool = False, timeout_s: float = 5.0) -> None:
    if rp.proc is not None:
        end_child(rp.proc, timeout_s, kill=kill)
    if rp.log_file is not None:
        rp.log_file.close()
        rp.log_file = None


class RobotSupervisor:
    """The robot processes of a run: start, kill, notice deaths (`RobotProcesses`)."""

    def __init__(self, specs: Mapping[str, ProcessSpec], log_path: Callable[[str], Path],
                 env: dict[str, str], nice: int = 0) -> None:
        self.specs = dict(specs)
        self._log_path = log_path
        self._env = env
        self._nice = nice
        self.robots: dict[str, RobotProcess] = {}
        self._starts: dict[str, int] = {}
        self._lock = threading.Lock()
        self._launcher: RobotLauncher | None = None
        if any(self._launchable(spec) for spec in self.specs.values()):
            self._launcher = RobotLauncher(env)

    @staticmethod
    def _launchable(spec: ProcessSpec) -> bool:
        """A robot run here by the `murdoch-robot` of this installation is forked by the
        launcher; one placed elsewhere (`launch`) or another program is started by exec."""
        return not spec.launch and spec.command == tuple(robot_command())

    def add(self, name: str, port: int) -> None:
        self.robots[name] = RobotProcess(name, port)

    def names(self) -> list[str]:
        return list(self.robots)

    def start(self, name: str) -> int:
        with self._lock:
            rp = self.robots[name]
            start = self._starts.get(name, 0)
            self._starts[name] = start + 1
            spec = self.specs[name]
            if self._launcher is not None and self._launchable(spec):
                try:
                    rp.proc = self._launcher.start(
                        spec.arguments(port=rp.port, instance=start), self._log_path(name),
                        self._nice)
                    return rp.proc.pid
                except LauncherGone as exc:
                    log.warning("robots are started by exec from here on: %s", exc)
                    self._close_launcher()
            argv = spec.argv(port=rp.port, instance=start)
            start_robot(rp, argv, self._log_path(name), self._nice, self._env)
            assert rp.proc is not None
            return rp.proc.pid

    def _close_launcher(self) -> None:
        if self._launcher is not None:
            self._launcher.close()
            self._launcher = None

    def kill(self, name: str) -> int | None:
        with self._lock:
            rp = self.robots[name]
            pid = rp.proc.pid if rp.proc is not None and rp.proc.poll() is None else None
            stop_robot(rp, kill=True)
            rp.proc = None
            return pid

    def exited(self) -> list[tuple[str, int, int]]:
        out = []
        with self._lock:
            for name, rp in self.robots.items():
                proc = rp.proc
                code = None if proc is None else proc.poll()
                if proc is not None and code is not None:
                    out.append((name, proc.pid, code))
                    stop_robot(rp)
                    rp.proc = None
        return out

    def pause(self, name: str, paused: bool) -> int | None:
        with self._lock:
            proc = self.robots[name].proc
            if proc is None or proc.poll() is not None:
                return None
            proc.send_signal(signal.SIGSTOP if paused else signal.SIGCONT)
            return proc.pid

    def alive_test(self, name: str) -> Callable[[], bool]:
        """A test of whether the robot's current process is still running."""
        rp = self.robots[name]

        def alive() -> bool:
            proc = rp.proc
            return proc is not None and proc.poll() is None

        return alive

    def pids(self) -> dict[str, int]:
        with self._lock:
            return {f"robot-{n}": rp.proc.pid for n, rp in self.robots.items()
                    if rp.proc is not None and rp.proc.poll() is None}

    def process_robots(self) -> dict[str, int]:
        """Processes running more than one robot: none here."""
        return {}

    def stop_all(self) -> None:
        with self._lock:
            for rp in self.robots.values():
                stop_robot(rp)
            self._close_launcher()
