"""Stopping a child process a test started: politely, then by force, within bounds."""

from __future__ import annotations

import subprocess


def stop(proc: subprocess.Popen, grace_s: float = 15.0) -> None:
    """SIGTERM `proc` and wait up to `grace_s` for it; SIGKILL it if it has not gone by then.
    Does nothing to a process that has already exited."""
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(grace_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
