"""A robot launcher: one process that has imported the robot, forking a robot per request.

A `murdoch-robot` process spends most of its start-up importing (about 0.3 s of CPU, seven
times over for the long-term team, on every run). A run's robots are all the same program
with different arguments, so the runner starts one launcher (`python -m behaviors.launcher`)
that imports the robot once and then forks a child per robot: each child is a process of its
own (its own pid, log, priority, signals and exit code), which runs exactly what
`murdoch-robot ARGS` runs.

Lines on standard input, one JSON object each, ask for a robot::

    {"id": 3, "argv": [...murdoch-robot arguments...], "log": "/run/logs/robot-p1.log",
     "nice": 10}

Lines on standard output answer, and report every child's end as the launcher reaps it::

    {"id": 3, "pid": 4242}             started
    {"id": 3, "error": "..."}          could not be started
    {"pid": 4242, "code": -9}          ended (negative: the signal that ended it)

The launcher is single-threaded and forks only from its main thread. It ends when its
standard input closes; children still running carry on (as processes started with exec
would) and are reaped by the system.
"""

from __future__ import annotations

import contextlib
import gc
import json
import os
import select
import signal
import sys
import traceback
from typing import Any

# what `murdoch-robot` imports, at start and when it builds a robot (see behaviors.__main__)
import behaviors.__main__ as robot_main
import behaviors.murdoch_link
import murdoch.auth
import murdoch.endpoint
import murdoch.lossy
import murdoch.multicast
import murdoch.transport
import murdoch.transport_choice
import worlds  # noqa: F401

PRELOADED = (behaviors.murdoch_link, murdoch.auth, murdoch.endpoint, murdoch.lossy,
             murdoch.multicast, murdoch.transport, murdoch.transport_choice)


def _run_child(argv: list[str], log: str, fds: tuple[int, ...]) -> None:
    """In the forked child: become `murdoch-robot argv`, writing to `log`; never returns."""
    code = 1
    try:
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        for fd in fds:
            os.close(fd)
        out = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.dup2(out, 1)
        os.dup2(out, 2)
        os.close(out)
        os.close(null)
        sys.argv = ["murdoch-robot", *argv]
        code = robot_main.main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:
        traceback.print_exc()
    finally:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _start(request: dict[str, Any], fds: tuple[int, ...]) -> dict[str, Any]:
    rid = request.get("id")
    try:
        argv = [str(a) for a in request["argv"]]
        log = str(request["log"])
        nice = int(request.get("nice", 0))
    except (KeyError, TypeError, ValueError) as exc:
        return {"id": rid, "error": f"a request needs argv, log and nice: {exc}"}
    sys.stdout.flush()
    try:
        pid = os.fork()
    except OSError as exc:
        return {"id": rid, "error": f"fork failed: {exc}"}
    if pid == 0:
        _run_child(argv, log, fds)
    if nice > 0:  # before the pid is handed back, as the runner does for a robot it execs
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, pid, nice)
    return {"id": rid, "pid": pid}


def _reap() -> list[dict[str, Any]]:
    ended = []
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            break
        if pid == 0:
            break
        ended.append({"pid": pid, "code": os.waitstatus_to_exitcode(status)})
    return ended


def _say(reply: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(reply) + "\n")
    sys.stdout.flush()


def serve() -> int:
    """Answer requests on standard input until it closes (see the module's doc)."""
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_w, False)
    os.set_blocking(wake_r, False)
    signal.set_wakeup_fd(wake_w)
    signal.signal(signal.SIGCHLD, lambda signum, frame: None)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the runner ends the robots, then us
    stdin = sys.stdin.fileno()
    fds = (wake_r, wake_w)
    pending = b""
    gc.collect()
    gc.freeze()  # what the import built is shared by every child: keep it off the collector
    _say({"ready": os.getpid()})
    while True:
        ready, _, _ = select.select([stdin, wake_r], [], [])
        if wake_r in ready:
            with contextlib.suppress(BlockingIOError):
                while os.read(wake_r, 512):
                    pass
        for ended in _reap():
            _say(ended)
        if stdin not in ready:
            continue
        chunk = os.read(stdin, 65536)
        if not chunk:
            return 0
        pending += chunk
        *lines, pending = pending.split(b"\n")
        for line in lines:
            if not line.strip():
                continue
            try:
                request = json.loads(line)
            except ValueError as exc:
                _say({"error": f"not a JSON request: {exc}"})
                continue
            if not isinstance(request, dict):
                _say({"error": "a request is a JSON object"})
                continue
            _say(_start(request, fds))
        for ended in _reap():
            _say(ended)


if __name__ == "__main__":
    sys.exit(serve())
