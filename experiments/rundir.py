"""The run directory: ``runs/<experiment>-<YYYYmmdd-HHMMSS>/`` and what lives in it.

    config.json     the effective configuration, including the seed and the world file
    events.jsonl    every event of the run (see `experiments.events`)
    run.mcap        the recording: poses, sensors, batteries, states, events (for Foxglove,
                    the Player replay and replay.html; `experiments.recording`)
    processes.jsonl wall-clock measurements: process memory samples and the run's wall time
    summary.json    counts as in the paper (`experiments.summary`)
    plots/          tasks.png, battery.png, allocation.png (`experiments.plots`)
    replay.html     offline meshcat animation (`experiments.replay`)
    logs/           one log file per process
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

CONFIG = "config.json"
EVENTS = "events.jsonl"
RECORDING = "run.mcap"
PROCESSES = "processes.jsonl"
SUMMARY = "summary.json"
PLOTS = "plots"
REPLAY = "replay.html"
LOGS = "logs"

_NAME_RE = re.compile(r"^[A-Za-z0-9_.-]+$")


@dataclass(frozen=True, slots=True)
class RunDir:
    root: Path

    @property
    def config(self) -> Path:
        return self.root / CONFIG

    @property
    def events(self) -> Path:
        return self.root / EVENTS

    @property
    def recording(self) -> Path:
        return self.root / RECORDING

    @property
    def processes(self) -> Path:
        """Wall-clock measurements (memory samples, wall time): not part of the run's
        simulated history, so kept out of events.jsonl."""
        return self.root / PROCESSES

    @property
    def summary(self) -> Path:
        return self.root / SUMMARY

    @property
    def plots(self) -> Path:
        return self.root / PLOTS

    @property
    def replay(self) -> Path:
        return self.root / REPLAY

    @property
    def logs(self) -> Path:
        return self.root / LOGS

    def log_file(self, process_name: str) -> Path:
        if not _NAME_RE.match(process_name):
            raise ValueError(f"process name {process_name!r} is not usable as a file name")
        return self.logs / f"{process_name}.log"

    def write_config(self, config: dict[str, Any]) -> None:
        if "seed" not in config:
            raise ValueError("the run configuration must record its seed")
        _write_json(self.config, config)

    def read_config(self) -> dict[str, Any]:
        data = json.loads(self.config.read_text(encoding="utf-8"))
        if not isinstance(data, dict):
            raise ValueError(f"{self.config}: expected a JSON object")
        return data

    def write_summary(self, summary: dict[str, Any]) -> None:
        _write_json(self.summary, summary)


def write_text_atomic(path: Path, text: str) -> None:
    """Write `text` to ``<path>.tmp`` and rename it over `path`: readers see the old file or
    the whole new one. On failure (a full disk) the temporary file is removed and the error
    raised."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _write_json(path: Path, data: Any) -> None:
    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n")


def create_run_dir(out: Path, experiment: str, started: datetime) -> RunDir:
    """Make a fresh ``<out>/<experiment>-<timestamp>`` (with -2, -3... if taken)."""
    if not _NAME_RE.match(experiment):
        raise ValueError(f"experiment name {experiment!r} is not usable as a directory name")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    base = f"{experiment}-{started.strftime('%Y%m%d-%H%M%S')}"
    for n in range(1, 1000):
        root = out / (base if n == 1 else f"{base}-{n}")
        try:
            root.mkdir()
        except FileExistsError:
            continue
        (root / PLOTS).mkdir()
        (root / LOGS).mkdir()
        return RunDir(root)
    raise RuntimeError(f"too many runs named {base} in {out}")


def open_run_dir(path: Path) -> RunDir:
    """An existing run directory; a clear error when it is not one."""
    root = Path(path)
    if not root.is_dir():
        raise FileNotFoundError(f"{root} is not a directory")
    if not (root / EVENTS).is_file():
        raise FileNotFoundError(f"{root} has no {EVENTS}: not a run directory")
    (root / PLOTS).mkdir(exist_ok=True)
    return RunDir(root)
