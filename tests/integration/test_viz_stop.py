"""`python -m player_server.viz` takes its viewer (bridge) process with it when it stops."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(180)


def _children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _gone(pid: int, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return True
        if state == "Z":  # exited, not yet reaped by its (new) parent
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.1)


def _port_refused(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(2.0)
        return s.connect_ex(("127.0.0.1", port)) != 0


def _start_viz() -> tuple[subprocess.Popen[str], int, int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "player_server.viz", "--world", "simple",
         "--sim-seconds", "100000", "--speedup", "1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()  # the URL line, once the viewer is up
    m = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
    assert m, line
    bridges = _children(proc.pid)
    assert len(bridges) == 1, bridges
    return proc, bridges[0], int(m.group(1))


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_stopping_the_viewer_command_stops_its_bridge(how: str) -> None:
    proc, bridge, web_port = _start_viz()
    try:
        assert not _port_refused(web_port)
        os.kill(proc.pid, getattr(signal, how))
        proc.wait(30)
        if how == "SIGTERM":
            assert proc.returncode == 0
        assert _gone(bridge, 30.0), f"bridge {bridge} outlived its owner after {how}"
        assert _port_refused(web_port)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        if not _gone(bridge, 0.0):
            os.kill(bridge, signal.SIGKILL)
