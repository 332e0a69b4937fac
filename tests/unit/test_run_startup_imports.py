"""A run starts without importing what only its end needs: matplotlib is imported when the
run's plots are drawn (`experiments.report.build_report`), not while the robots wait for the
first tick."""

from __future__ import annotations

import subprocess
import sys

_STARTUP = """
import sys
import experiments.cli, experiments.run_cli, experiments.run_parts, experiments.recorder
import experiments.report, experiments.recording
from experiments.registry import experiments
assert {"longterm", "boxpush"} <= set(experiments())
print(sorted(m for m in sys.modules if m.split(".")[0] == "matplotlib"))
"""


def test_the_modules_a_run_starts_with_do_not_import_matplotlib() -> None:
    done = subprocess.run([sys.executable, "-c", _STARTUP], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "[]", done.stdout
