"""Robots run K to a process (`murdoch run --robots-per-process K`, K > 1).

The run's robots, in the world's order, are grouped K at a time (`group_robots`); each group
is one host process (`behaviors.host`) that runs each of its robots as a thread doing what
a `murdoch-robot` process does. `HostSupervisor` is what `experiments.run_loop` asks of the
run's process supervision (`RobotProcesses`), on top of those hosts: starting a robot sends
``start NAME ARG...`` to its host (started first if it is not running), killing one sends
``kill NAME`` and waits until the host says the robot is cut off (so, as with a killed
process, nothing the robot does afterwards is seen), and a robot that ended by itself is
told by its host, or by the host process ending. Pausing one robot is refused: the robots of
a host stop and continue together.

Pids are the hosts' (processes.jsonl samples each host once, as ``host-I`` with the number of
robots it runs).
"""

from __future__ import annotations

import contextlib
import logging
import os
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from behaviors.host_control import Kill, Start, Status, parse_status
from experiments.supervisor import ProcessSpec
from player_server.children import end_child

log = logging.getLogger("murdoch.run")

KILL_ACK_S = 30.0
"""How long a kill waits for the host to say the robot is cut off (wall seconds)."""


class PauseRefused(RuntimeError):
    """A robot sharing its process with others cannot be paused alone."""


AUTO_MAX_PER_PROCESS = 100
"""`--robots-per-process auto`: a host process runs at most this many robots."""


def robots_per_process(choice: int | None, members: int, *, placed: bool,
                       pausing: bool, cpus: int = 2) -> int:
    """Robots to a process: `choice` when given; for ``auto`` (None) one each when a robot is
    placed on another host (`placed`) or paused alone by the fault schedule (`pausing`), else
    the team spread evenly over one host per CPU left to the robots (`cpus` the run may use,
    less one for the serving thread), at most `AUTO_MAX_PER_PROCESS` to a host (on two CPUs
    a team of up to a hundred is one host). The robots of a host share one interpreter
    lock, so more hosts than CPUs only add processes that wake every tick
    (`docs/experiments.md`: on two CPUs the long-term team ran faster as one host than as a
    process per robot, and swarm100 faster as one host of a hundred than as ten hosts of
    ten). A lockstep run's events do not depend on it (the robots of a host act at tick
    boundaries alike)."""
    if choice is not None:
        return choice
    if placed or pausing:
        return 1
    robot_cpus = max(1, cpus - 1)
    return min(AUTO_MAX_PER_PROCESS, -(-members // robot_cpus))


def group_robots(names: list[str], per_process: int) -> list[tuple[str, ...]]:
    """`names` in order, `per_process` to a group (the last may have fewer)."""
    if per_process < 1:
        raise ValueError(f"robots per process must be at least 1, found {per_process}")
    return [tuple(names[i:i + per_process]) for i in range(0, len(names), per_process)]


def host_name(index: int) -> str:
    return f"host-{index}"


def host_command() -> list[str]:
    """The host process's command (`behaviors.host`) with this interpreter."""
    return [sys.executable, "-m", "behaviors.host"]


@dataclass
class _Host:
    name: str
    robots: tuple[str, ...]
    proc: subprocess.Popen[bytes] | None = None
    log_file: IO[bytes] | None = None
    up: set[str] = field(default_factory=set)
    """Robots whose threads run, as far as the host has told."""
    exits: list[tuple[str, int]] = field(default_factory=list)
    acks: set[str] = field(default_factory=set)
    """Robots the host said it cut off (or found not running) since asked."""

    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None


class HostSupervisor:
    """The robot processes of a run, K robots to a host process (see the module)."""

    def __init__(self, specs: Mapping[str, ProcessSpec], groups: list[tuple[str, ...]],
                 log_path: Callable[[str], Path], env: dict[str, str], nice: int = 0,
                 command: list[str] | None = None) -> None:
        self.specs = dict(specs)
        self.hosts = [_Host(host_name(i), g) for i, g in enumerate(groups)]
        self._host_of = {n: h for h in self.hosts for n in h.robots}
        self._log_path = log_path
        self._env = env
        self._nice = nice
        self._command = command or host_command()
        self._ports: dict[str, int] = {}
        self._starts: dict[str, int] = {}
        self._lost: list[tuple[str, int, int]] = []
        self._changed = threading.Condition()

    def add(self, name: str, port: int) -> None:
        self._ports[name] = port

    def names(self) -> list[str]:
        return list(self._ports)

    def layout(self) -> list[dict[str, object]]:
        """The hosts and their robots (config.json)."""
        return [{"name": h.name, "command": self._command, "robots": list(h.robots)}
                for h in self.hosts]

    # -- RobotProcesses -----------------------------------------------------------------------
    def start(self, name: str) -> int:
        host = self._host_of[name]
        with self._changed:
            if not host.running():
                self._lost += self._reap(host)  # told by the next `exited`
                self._start_host(host)
            start = self._starts.get(name, 0)
            self._starts[name] = start + 1
            args = self.specs[name].arguments(port=self._ports[name], instance=start)
            host.up.add(name)
            self._send(host, Start(name, tuple(args)).line())
            assert host.proc is not None
            return host.proc.pid

    def kill(self, name: str) -> int | None:
        host = self._host_of[name]
        with self._changed:
            if name not in host.up or not host.running():
                host.up.discard(name)
                return None
            assert host.proc is not None
            pid = host.proc.pid
            host.acks.discard(name)
            self._send(host, Kill(name).line())
            acked = self._changed.wait_for(
                lambda: name in host.acks or not host.running(), KILL_ACK_S)
            if not acked:
                log.error("host %s did not cut robot %s off within %.0f s; ending the host",
                          host.name, name, KILL_ACK_S)
                end_child(host.proc, kill=True)
            host.up.discard(name)
            host.exits = [(n, c) for n, c in host.exits if n != name]
            return pid

    def exited(self) -> list[tuple[str, int, int]]:
        with self._changed:
            out, self._lost = self._lost, []
            for host in self.hosts:
                out += self._reap(host)
        return out

    def _reap(self, host: _Host) -> list[tuple[str, int, int]]:
        """(name, pid, code) of the host's robots that ended by themselves, and of all of
        them if the host process ended (with its code); the lock is held."""
        if host.proc is None:
            return []
        pid = host.proc.pid
        out = [(name, pid, code) for name, code in host.exits if name in host.up]
        host.up -= {name for name, _, _ in out}
        host.exits.clear()
        if not host.running():
            code = int(host.proc.returncode)
            out += [(name, pid, code) for name in sorted(host.up)]
            host.up.clear()
            self._end_host(host)
        return out

    def pause(self, name: str, paused: bool) -> int | None:
        raise PauseRefused(f"robot {name} shares its process with others (--robots-per-process "
                           "above 1): it cannot be paused alone")

    def alive_test(self, name: str) -> Callable[[], bool]:
        host = self._host_of[name]

        def alive() -> bool:
            return name in host.up and host.running()

        return alive

    def pids(self) -> dict[str, int]:
        with self._changed:
            return {h.name: h.proc.pid for h in self.hosts
                    if h.proc is not None and h.running()}

    def process_robots(self) -> dict[str, int]:
        """How many robots each host process runs (processes.jsonl)."""
        return {h.name: len(h.robots) for h in self.hosts}

    def stop_all(self) -> None:
        with self._changed:
            hosts = [h for h in self.hosts if h.proc is not None]
            for host in hosts:  # end of input: every host stops its robots at once
                if host.proc is not None and host.proc.stdin is not None:
                    with contextlib.suppress(OSError):
                        host.proc.stdin.close()
        for host in hosts:
            if host.proc is not None:
                end_child(host.proc, timeout_s=15.0)
            with self._changed:
                self._end_host(host)

    # -- the hosts ------------------------------------------------------------------------------
    def _start_host(self, host: _Host) -> None:
        if host.log_file is None:
            host.log_file = self._log_path(host.name).open("ab")
        host.proc = proc = subprocess.Popen(
            self._command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=host.log_file, env=self._env)
        host.up.clear()
        host.exits.clear()
        host.acks.clear()
        if self._nice > 0:
            try:
                os.setpriority(os.PRIO_PROCESS, proc.pid, self._nice)
            except OSError as exc:
                log.warning("could not lower the priority of %s: %s", host.name, exc)
        threading.Thread(target=self._read_status, args=(host, proc),
                         name=f"{host.name}-status", daemon=True).start()

    def _read_status(self, host: _Host, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stdout is not None
        try:
            for raw in proc.stdout:
                status = parse_status(raw.decode("utf-8", "replace"))
                if status is not None:
                    self._on_status(host, proc, status)
        except (OSError, ValueError):  # the pipe was closed: the host is being ended
            pass
        proc.wait()
        with self._changed:
            self._changed.notify_all()

    def _on_status(self, host: _Host, proc: subprocess.Popen[bytes], status: Status) -> None:
        with self._changed:
            if host.proc is not proc:
                return  # an earlier process of this host
            if status.what in ("killed", "not-running"):
                host.acks.add(status.name)
            elif status.what == "exited":
                host.exits.append((status.name, status.code))
            elif status.what == "refused":
                log.error("host %s refused a command: %s", host.name, status.text)
            self._changed.notify_all()

    def _send(self, host: _Host, line: str) -> None:
        proc = host.proc
        if proc is None or proc.stdin is None:
            return
        try:
            proc.stdin.write(line.encode() + b"\n")
            proc.stdin.flush()
        except OSError as exc:  # the host has gone: its robots are told as exited
            log.warning("host %s: %s", host.name, exc)

    def _end_host(self, host: _Host) -> None:
        proc = host.proc
        if proc is not None:
            for pipe in (proc.stdin, proc.stdout):
                if pipe is not None:
                    with contextlib.suppress(OSError):
                        pipe.close()
        host.proc = None
        if host.log_file is not None:
            host.log_file.close()
            host.log_file = None
