"""The robot launcher (`behaviors.launcher`) forks real `murdoch-robot` processes: each acts,
exits, logs, takes signals and priority as one started by exec, and the runner falls back to
exec when the launcher is gone."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from experiments.robot_launcher import LaunchedRobot, LauncherGone, RobotLauncher
from experiments.supervisor import ProcessSpec, RobotSupervisor, robot_command

pytestmark = pytest.mark.timeout(60)

REPO = Path(__file__).resolve().parents[2]
WORLD = str(REPO / "worlds" / "longterm.toml")


def _refused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def launcher() -> Iterator[RobotLauncher]:
    la = RobotLauncher(dict(os.environ))
    yield la
    la.close()


@pytest.fixture
def silent_server() -> Iterator[int]:
    """A port that accepts connections and never says anything (a robot waits on it)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen(8)
        yield int(s.getsockname()[1])


def _state(pid: int) -> str:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return fields[0]


def _wait_for_state(pid: int, want: str) -> str:
    deadline = time.monotonic() + 10
    state = _state(pid)
    while state != want and time.monotonic() < deadline:
        time.sleep(0.02)
        state = _state(pid)
    return state


def test_a_launched_robot_says_and_exits_as_the_exec_one_does(
        launcher: RobotLauncher, tmp_path: Path) -> None:
    argv = ["-p", str(_refused_port()), "--name", "p1", "--world", WORLD]
    robot = launcher.start(argv, tmp_path / "forked.log")
    code = robot.wait(30)
    execd = subprocess.run([*robot_command(), *argv], capture_output=True, text=True,
                           timeout=30)
    assert code == execd.returncode == 1
    said = (tmp_path / "forked.log").read_text()
    assert said == execd.stderr + execd.stdout
    assert said.startswith("murdoch-robot: cannot connect to 127.0.0.1:")


def test_bad_arguments_end_with_argparses_code_and_message(
        launcher: RobotLauncher, tmp_path: Path) -> None:
    robot = launcher.start(["-p", "1", "--no-such-option"], tmp_path / "r.log")
    assert robot.wait(30) == 2
    log = (tmp_path / "r.log").read_text()
    assert "murdoch-robot: error: " in log and "--no-such-option" in log


def test_signals_priority_and_exit_code_of_a_launched_robot(
        launcher: RobotLauncher, silent_server: int, tmp_path: Path) -> None:
    robot = launcher.start(["-p", str(silent_server), "--name", "p1", "--world", WORLD],
                           tmp_path / "r.log", nice=5)
    assert robot.poll() is None
    assert os.getpriority(os.PRIO_PROCESS, robot.pid) == 5  # as given, at once
    robot.send_signal(signal.SIGSTOP)
    assert _wait_for_state(robot.pid, "T") == "T"
    robot.send_signal(signal.SIGCONT)
    assert _wait_for_state(robot.pid, "S") in ("S", "R")
    with pytest.raises(subprocess.TimeoutExpired):
        robot.wait(0.2)
    robot.kill()
    assert robot.wait(10) == -signal.SIGKILL
    assert robot.poll() == robot.returncode == -signal.SIGKILL
    robot.kill()  # ended: nothing to signal, no error


def test_a_malformed_request_is_answered_and_the_launcher_goes_on(tmp_path: Path) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "behaviors.launcher"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdin is not None and proc.stdout is not None
    try:
        assert "ready" in proc.stdout.readline()
        proc.stdin.write("{not json\n[1, 2]\n{\"id\": 1}\n")
        proc.stdin.flush()
        assert "not a JSON request" in proc.stdout.readline()
        assert "a request is a JSON object" in proc.stdout.readline()
        assert "needs argv, log and nice" in proc.stdout.readline()
        proc.stdin.write('{"id": 2, "argv": ["--no-such-option"], "log": "%s", "nice": 0}\n'
                         % (tmp_path / "r.log"))
        proc.stdin.flush()
        started = proc.stdout.readline()
        assert '"id": 2' in started and '"pid"' in started
        assert '"code": 2' in proc.stdout.readline()
    finally:
        proc.stdin.close()
        assert proc.wait(10) == 0


def test_robots_are_started_by_exec_once_the_launcher_is_gone(
        silent_server: int, tmp_path: Path) -> None:
    spec = ProcessSpec("p1", tuple(robot_command()),
                       ("-p", "{port}", "--name", "p1", "--world", WORLD))
    sup = RobotSupervisor({"p1": spec}, lambda n: tmp_path / f"robot-{n}.log",
                          dict(os.environ))
    sup.add("p1", silent_server)
    try:
        sup.start("p1")
        assert isinstance(sup.robots["p1"].proc, LaunchedRobot)
        sup.kill("p1")
        launcher = sup._launcher
        assert launcher is not None
        launcher._proc.kill()
        launcher._proc.wait(10)
        with pytest.raises(LauncherGone):
            launcher.start(["--help"], tmp_path / "x.log")
        pid = sup.start("p1")
        proc = sup.robots["p1"].proc
        assert isinstance(proc, subprocess.Popen) and proc.pid == pid
        assert proc.poll() is None
    finally:
        sup.stop_all()
    assert sup.robots["p1"].proc is None or sup.robots["p1"].proc.poll() is not None
