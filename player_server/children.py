"""Ending a child process: ask it to end, wait, and kill it when it does not.

The run's robot processes and the live viewer's process end this way.
"""

from __future__ import annotations

import signal
import subprocess
from typing import Protocol


class ChildProcess(Protocol):
    """What ending a child needs of it: `subprocess.Popen`, or a robot the run's launcher
    forked (`experiments.robot_launcher.LaunchedRobot`)."""

    @property
    def pid(self) -> int: ...

    @property
    def returncode(self) -> int | None: ...

    def poll(self) -> int | None: ...

    def wait(self, timeout: float | None = None) -> int: ...

    def send_signal(self, sig: int) -> None: ...

    def terminate(self) -> None: ...

    def kill(self) -> None: ...


def end_child(proc: ChildProcess, timeout_s: float = 5.0, *,
              kill: bool = False) -> None:
    """End `proc` if it still runs: SIGTERM (after SIGCONT, since a stopped process could not
    act on it), or SIGKILL right away with `kill`; SIGKILL if it has not ended within
    `timeout_s`. Returns once it has been reaped."""
    if proc.poll() is not None:
        return
    if kill:
        proc.kill()
    else:
        proc.send_signal(signal.SIGCONT)
        proc.terminate()
    try:
        proc.wait(timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout_s)
