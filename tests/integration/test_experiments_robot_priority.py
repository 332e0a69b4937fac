"""Robot processes started by the runner get the niceness asked for (a real child process)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from experiments.run_cli import RobotProcess, _start_robot, _stop_robot

pytestmark = pytest.mark.timeout(30)

SLEEPER = [sys.executable, "-c", "import time; time.sleep(20)"]


@pytest.mark.parametrize("nice", [0, 7])
def test_robot_process_niceness(tmp_path: Path, nice: int) -> None:
    rp = RobotProcess("r1", 0)
    own = os.getpriority(os.PRIO_PROCESS, 0)
    _start_robot(rp, SLEEPER, tmp_path / "r1.log", nice)
    try:
        assert rp.proc is not None
        assert os.getpriority(os.PRIO_PROCESS, rp.proc.pid) == (nice if nice else own)
    finally:
        _stop_robot(rp)
    assert rp.proc.poll() is not None
