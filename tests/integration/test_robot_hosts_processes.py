"""A real host process of robots (`python -m behaviors.host`) under `HostSupervisor`: one
robot failing leaves the others running, a kill cuts one robot off at once (its connection
ends without a byte), a robot starts again in the same process, a pause is refused."""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

import pytest

from experiments.robot_hosts import HostSupervisor, PauseRefused
from experiments.supervisor import ProcessSpec

pytestmark = pytest.mark.timeout(120)


def _refused_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _exits(sup: HostSupervisor, wait_s: float = 30.0) -> list[tuple[str, int, int]]:
    """The next exits the supervisor tells (bounded wait)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        found = sup.exited()
        if found:
            return found
        time.sleep(0.05)
    return []


def test_a_host_goes_on_when_a_robot_fails_and_cuts_one_off_on_a_kill(tmp_path: Path) -> None:
    refused = _refused_port()
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        listener.settimeout(30.0)
        quiet = int(listener.getsockname()[1])  # accepts, never says a word
        specs = {
            "a": ProcessSpec("a", (), ("-p", "{port}", "--name", "a")),
            "b": ProcessSpec("b", (), ("-p", "{port}", "--name", "b", "--request-timeout",
                                       "60", "--instance", "{instance}")),
        }
        sup = HostSupervisor(specs, [("a", "b")], lambda n: tmp_path / f"{n}.log",
                             env={**os.environ})
        sup.add("a", refused)
        sup.add("b", quiet)
        try:
            pid = sup.start("a")
            assert sup.start("b") == pid
            assert sup.pids() == {"host-0": pid}
            alive_b = sup.alive_test("b")
            # a cannot connect: told as exited with its code; b goes on
            assert _exits(sup) == [("a", pid, 1)]
            conn, _ = listener.accept()  # b's handshake waits for the banner
            assert alive_b()
            assert sup.kill("b") == pid
            assert not alive_b()
            conn.settimeout(10.0)
            with conn:
                assert conn.recv(64) == b""  # dropped at once, nothing sent
            assert sup.kill("b") is None
            with pytest.raises(PauseRefused, match="cannot be paused alone"):
                sup.pause("a", True)
            # a starts again in the same host process, and fails again
            assert sup.start("a") == pid
            assert _exits(sup) == [("a", pid, 1)]
            assert sup.exited() == []  # the killed robot is never told as exited
        finally:
            sup.stop_all()
        assert sup.pids() == {}
    log = (tmp_path / "host-0.log").read_text(errors="replace")
    assert "murdoch-robot a: cannot connect" in log
    assert "Traceback" not in log
