"""The runner's side of the robot launcher (`behaviors.launcher`): robots forked from one
process that imported the robot once, each handed back as a `LaunchedRobot` that is waited
on, signalled and killed as a `subprocess.Popen` is.

`RobotLauncher.start` fails with `LauncherGone` when the launcher cannot start a robot (it
could not be started, or it ended); the supervisor then starts robots by exec as before.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import IO, Any

log = logging.getLogger("murdoch.run")

READY_TIMEOUT_S = 60.0
"""How long the launcher may take to import the robot (a loaded machine) before robots are
started by exec instead."""


class LauncherGone(RuntimeError):
    """The launcher cannot start robots (any more)."""


class LaunchedRobot:
    """A robot process forked by the launcher: `pid`, `poll`, `wait`, `send_signal`,
    `terminate`, `kill` and `returncode` as `subprocess.Popen` has them. The launcher, its
    parent, reaps it and reports its exit code, so `poll` sees the end once that report
    has been read (within milliseconds)."""

    def __init__(self, pid: int, args: list[str]) -> None:
        self.pid = pid
        self.args = args
        self.returncode: int | None = None
        self._ended = threading.Event()
        self._orphaned = False

    def _end(self, code: int) -> None:
        self.returncode = code
        self._ended.set()

    def _orphan(self) -> None:
        """The launcher ended before this robot did: from here on its end is seen by its
        pid going away (the system reaps it), its exit code unknown (-1)."""
        self._orphaned = True

    def poll(self) -> int | None:
        if self.returncode is None and self._orphaned:
            try:
                os.kill(self.pid, 0)
            except ProcessLookupError:
                self._end(-1)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self._orphaned and self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            time.sleep(0.05)
        if not self._ended.wait(timeout):
            raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
        assert self.returncode is not None
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.returncode is None:
            with contextlib.suppress(ProcessLookupError):  # ended: its report is on its way
                os.kill(self.pid, sig)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


class RobotLauncher:
    """Owns one `behaviors.launcher` process and the thread that reads its replies."""

    def __init__(self, env: dict[str, str] | None = None,
                 ready_timeout_s: float = READY_TIMEOUT_S) -> None:
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "behaviors.launcher"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, bufsize=0)
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._requests: IO[bytes] = self._proc.stdin
        self._lock = threading.Lock()
        self._next_id = 0
        self._answers: dict[int, dict[str, Any]] = {}
        self._children: dict[int, LaunchedRobot] = {}
        self._early_ends: dict[int, int] = {}
        self._changed = threading.Condition(self._lock)
        self._ready = False
        self._gone = False
        self._reader = threading.Thread(target=self._read, args=(self._proc.stdout,),
                                        name="robot-launcher", daemon=True)
        self._reader.start()
        self._ready_timeout_s = ready_timeout_s

    def _read(self, replies: IO[bytes]) -> None:
        for line in replies:
            try:
                reply = json.loads(line)
            except ValueError:
                continue
            with self._changed:
                if "ready" in reply:
                    self._ready = True
                elif "id" in reply:
                    self._answers[int(reply["id"])] = reply
                elif "code" in reply:
                    pid, code = int(reply["pid"]), int(reply["code"])
                    child = self._children.pop(pid, None)
                    if child is None:
                        self._early_ends[pid] = code  # ended before its start was read
                    else:
                        child._end(code)
                self._changed.notify_all()
        with self._changed:
            self._gone = True
            for child in self._children.values():
                child._orphan()
            self._changed.notify_all()

    def start(self, argv: list[str], log_path: Path, nice: int = 0,
              timeout_s: float = 30.0) -> LaunchedRobot:
        """Fork a robot running `murdoch-robot argv` (argv without the program), its output
        appended to `log_path`, at priority `nice`."""
        with self._changed:
            self._changed.wait_for(lambda: self._ready or self._gone, self._ready_timeout_s)
            if self._gone or not self._ready:
                raise LauncherGone("the robot launcher is not running")
            rid = self._next_id
            self._next_id += 1
            request = {"id": rid, "argv": argv, "log": str(log_path), "nice": nice}
            try:
                self._requests.write((json.dumps(request) + "\n").encode())
            except OSError as exc:
                raise LauncherGone(f"the robot launcher is gone: {exc}") from exc
            deadline = time.monotonic() + timeout_s
            while rid not in self._answers:
                left = deadline - time.monotonic()
                if self._gone or left <= 0:
                    raise LauncherGone("the robot launcher did not answer")
                self._changed.wait(left)
            answer = self._answers.pop(rid)
            if "pid" not in answer:
                raise LauncherGone(str(answer.get("error", answer)))
            child = LaunchedRobot(int(answer["pid"]), argv)
            code = self._early_ends.pop(child.pid, None)
            if code is None:
                self._children[child.pid] = child
            else:
                child._end(code)
            return child

    def close(self, timeout_s: float = 5.0) -> None:
        """End the launcher (robots it started are ended by their supervisor first)."""
        with contextlib.suppress(OSError):
            self._requests.close()
        try:
            self._proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait(timeout_s)
        self._reader.join(timeout_s)
        if self._proc.stdout is not None:
            self._proc.stdout.close()
