"""Everything derived from a run directory's events: summary.json, plots and replay.html.

The runner calls `build_report` when a run ends and `murdoch report RUN_DIR` calls it again on
demand, so a report can always be rebuilt from ``events.jsonl`` (and ``run.mcap``) alone.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiments import events as ev
from experiments import rundir as rd
from experiments.driven import PathLengths
from experiments.summary import summarize

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Report:
    run: rd.RunDir
    summary: dict[str, Any]
    plots: tuple[Path, ...]
    replay: Path | None
    malformed_lines: int
    # what could not be written (a full disk), one line each; summary.json comes first
    problems: tuple[str, ...] = ()


def world_of(run: rd.RunDir) -> Any | None:
    """The run's world spec, from the ``world`` entry of config.json (a path or a name)."""
    from worlds import load_world, world_path

    if not run.config.is_file():
        return None
    world = run.read_config().get("world")
    if not world:
        return None
    path = Path(world)
    return load_world(path if path.suffix == ".toml" else world_path(str(world)))


def recorded_poses(path: Path) -> Iterator[dict[str, Any]]:
    """The pose keyframes of a recording's /tf channel as ``poses`` events (replay.html)."""
    from player_server.record import channels as ch
    from player_server.record.reader import iter_messages

    for rec in iter_messages(path, topics=[ch.TF]):
        bodies = {name: [x, y, yaw] for name, (x, y, yaw) in ch.poses_of(rec.json()).items()}
        yield {"t": rec.t_s, "kind": ev.POSES, "bodies": bodies}


def path_lengths(frames: Iterable[Mapping[str, Any]], robots: Iterable[str]
                 ) -> dict[str, float]:
    """Metres each robot drove over ``poses`` events (`driven.PathLengths`)."""
    lengths = PathLengths(robots)
    for frame in frames:
        lengths.add(frame["bodies"])
    return lengths.by_robot()


def distance_driven(run: rd.RunDir, spec: Any) -> dict[str, Any] | None:
    """summary.json's `distance_m`: metres driven per robot and in all, from the recording's
    ground-truth poses (None without a recording)."""
    if spec is None or not run.recording.is_file():
        return None
    lengths = PathLengths(r.name for r in spec.robots if r.mobile)
    for frame in recorded_poses(run.recording):
        lengths.add(frame["bodies"])
    return lengths.summary()


def build_report(run: rd.RunDir, *, replay: bool = True, plots: bool = True,
                 distance: Mapping[str, Any] | None = None) -> Report:
    """summary.json, plots (unless not `plots`: those already in plots/ are left as they
    are) and (with `replay`) replay.html of a finished run. `distance`:
    the metres driven, summed by the runner while it recorded (`RunRecording.distance`);
    without it they are summed from run.mcap read back."""
    stats = ev.ReadStats()
    events = ev.read_events(run.events, stats=stats)
    processes = (ev.read_events(run.processes, stats=ev.ReadStats())
                 if run.processes.is_file() else [])
    from experiments.registry import experiment

    start = next((e for e in events if e["kind"] == ev.RUN_START), None)
    plugin = experiment(start.get("experiment") if start is not None else None)
    summary = summarize(events, processes, plugin)
    summary["events_sha256"] = (hashlib.sha256(run.events.read_bytes()).hexdigest()
                                if run.events.is_file() else None)
    summary["malformed_event_lines"] = stats.malformed
    config = run.read_config() if run.config.is_file() else {}
    summary["allocator"] = str(config.get("allocator", "murdoch"))
    summary["refine"] = bool(config.get("refine", False))
    spec = world_of(run)
    robots = tuple(r.name for r in spec.robots) if spec is not None else ()
    try:
        summary["distance_m"] = (dict(distance) if distance is not None
                                 else distance_driven(run, spec))
    except Exception as exc:  # a recording cut short or unreadable: the rest still stands
        log.warning("%s: distance driven not computed: %s", run.root, exc)
        summary["distance_m"] = None
    run.write_summary(summary)
    problems: list[str] = []
    drawn: tuple[Path, ...] = ()
    try:
        if plots:
            # (matplotlib is imported here, when a run has ended, not while a run starts)
            from experiments.plots import write_plots

            drawn = tuple(write_plots(events, run.plots, robots, plugin))
    except OSError as exc:
        problems.append(f"plots not written to {run.plots}: {exc.strerror or exc}")
    replay_path: Path | None = None
    if replay and not problems:
        try:
            replay_path = _write_replay(run, spec, events)
        except OSError as exc:
            problems.append(f"replay not written to {run.replay}: {exc.strerror or exc}")
    return Report(run, summary, drawn, replay_path, stats.malformed, tuple(problems))


def _write_replay(run: rd.RunDir, spec: Any, events: list[dict[str, Any]]) -> Path | None:
    if spec is None:
        log.warning("%s: no world in config.json; replay.html not built", run.root)
        return None
    if not run.recording.is_file():
        log.warning("%s: no %s; replay.html not built", run.root, rd.RECORDING)
        return None
    from experiments.replay import write_replay
    from player_server.viz.scene import layout_from_world

    info = write_replay(run.replay, layout_from_world(spec), recorded_poses(run.recording),
                        events, title=f"{run.root.name}")
    return info.path
