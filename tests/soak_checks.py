"""What every soak run under random faults must show, for the short soak of the default suite
and the opt-in long ones alike (importable as `soak_checks`)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from experiments.soak.report import PLOT_FILES, SOAK_JSON, SOAK_MD

INVARIANTS = ("terminal_states", "exclusive_execution", "reallocation_bound", "charging",
              "dead_controller_still", "memory_flat")


def murdoch_command() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]




def check_soak_run(run_dir: Path, output: str, code: int, burst_size: int) -> None:
    """What every soak run under random faults must show (the two-hour one too)."""
    assert code == 0, output[-3000:]
    report = json.loads((run_dir / SOAK_JSON).read_text())
    for name in INVARIANTS:
        verdict = report["invariants"][name]
        assert verdict["checked"] and verdict["held"], (name, verdict)
    assert report["all_held"]
    assert "drive commands inside dead spans" in report["invariants"]["dead_controller_still"][
        "note"]
    # every kind of fault was injected, and some took a task from its holder
    config = json.loads((run_dir / "config.json").read_text())
    actions = {f["action"] for f in config["faults"]}
    assert {"kill", "restart", "freeze", "thaw", "retire", "charger-off", "charger-on",
            "burst"} <= actions
    injected = report["faults_injected"]
    for kind in ("robot_failure:killed", "robot_freeze", "robot_thaw", "robot_switch_off",
                 "charger_off", "charger_on", "task_burst"):
        assert injected.get(kind, 0) >= 1, (kind, injected)
    assert report["reallocation_latency_s"]["count"] >= 1
    assert report["reallocation_latency_s"]["max"] <= report["limits"]["realloc_bound_s"]
    assert report["tasks_total"]["introduced"] >= burst_size + 10
    assert report["messages_per_hour"][0] > 0 and report["bytes_per_hour"][0] > 0
    assert report["memory"]["runner"]["slope_mib_per_h"] is not None
    for plot in PLOT_FILES:
        assert (run_dir / "plots" / plot).stat().st_size > 1000, plot
    md = (run_dir / SOAK_MD).read_text()
    assert "| reallocation_bound" in md and "held" in md
    assert "all invariants held" in output
