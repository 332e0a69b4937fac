"""Checks before a run starts, and one-line errors instead of tracebacks."""

from __future__ import annotations

import errno
import json
import pathlib
from datetime import datetime
from pathlib import Path

import pytest

from experiments import events as ev
from experiments import rundir as rd
from experiments.report import build_report
from experiments.run_checks import (
    RunSetupError,
    check_out_dir,
    check_schedule,
    describe_os_error,
    load_run_world,
)

ROBOTS = ("p1", "p2", "p3", "p4", "p5", "p6", "desk")


def _schedule_error(**kw: object) -> str:
    with pytest.raises(RunSetupError) as info:
        check_schedule(robots=ROBOTS, duration_s=600.0, world="longterm", **kw)  # type: ignore[arg-type]
    message = str(info.value)
    assert "\n" not in message
    return message


def test_a_good_schedule_passes() -> None:
    check_schedule(robots=ROBOTS, duration_s=3600.0, kills=[("p3", 1800.0)],
                   restarts=[("p3", 2700.0)])
    check_schedule(robots=ROBOTS, duration_s=600.0, kills=[("busy", 60.0)],
                   restarts=[("busy", 120.0)])


def test_unknown_robots_are_named_with_the_choices() -> None:
    m = _schedule_error(kills=[("p9", 60.0)])
    assert m.startswith("--kill p9@1m: no robot 'p9' in world longterm (robots: p1, p2")
    assert "busy" in m
    m = _schedule_error(switch_offs=[("busy", 60.0)])
    assert m.startswith("--switch-off busy@1m: no robot 'busy'")


def test_times_past_the_end_of_the_run_are_rejected() -> None:
    m = _schedule_error(kills=[("p3", 1800.0)], restarts=[("p3", 2700.0)])
    assert m == ("--kill p3@30m: 30m is at or past the end of the run (10m simulated); "
                 "give a longer --until")
    assert "at or past the end" in _schedule_error(kills=[("p3", 600.0)])
    assert "negative" in _schedule_error(kills=[("p3", -1.0)])


def test_a_restart_needs_a_kill_before_it() -> None:
    assert _schedule_error(restarts=[("p3", 60.0)]) == "--restart p3@1m: no --kill p3 before it"
    m = _schedule_error(kills=[("p3", 120.0)], restarts=[("p3", 60.0)])
    assert m == "--restart p3@1m: no --kill p3 before it"
    m = _schedule_error(switch_ons=[("p1", 60.0)])
    assert m == "--switch-on p1@1m: no --switch-off p1 before it"


def test_missing_and_bad_worlds_give_one_line(tmp_path: Path) -> None:
    with pytest.raises(RunSetupError) as info:
        load_run_world("longtrem")
    assert str(info.value).startswith("--world longtrem: no world named 'longtrem'")
    assert "longterm" in str(info.value)
    with pytest.raises(RunSetupError) as info:
        load_run_world(str(tmp_path / "missing.toml"))
    assert "missing.toml: no such world file" in str(info.value)
    bad = tmp_path / "bad.toml"
    bad.write_text("[arena]\nsize = 'big'\n")
    with pytest.raises(RunSetupError) as info:
        load_run_world(str(bad))
    assert "bad.toml" in str(info.value) and "\n" not in str(info.value)
    assert load_run_world("simple").robots


def test_stage_world_paths_are_world_files(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(RunSetupError) as info:
        load_run_world("missing.world")  # a file name, not a bundled world's name
    assert str(info.value) == "--world missing.world: no such world file"
    Path("bad.world").write_text("window ( size [ 100 100 ]\n")
    with pytest.raises(RunSetupError) as info:
        load_run_world("bad.world")
    assert "bad.world" in str(info.value) and "\n" not in str(info.value)


def test_unusable_output_directories_give_one_line(tmp_path: Path) -> None:
    for out, expected in ((Path("/proc/forbidden"), "--out /proc/forbidden: cannot write there"),
                          (Path("/sys/forbidden"), "--out /sys/forbidden: cannot write there")):
        with pytest.raises(RunSetupError) as info:
            check_out_dir(out)
        assert str(info.value).startswith(expected), info.value
        assert "\n" not in str(info.value)
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(RunSetupError, match="is a file, expected a directory"):
        check_out_dir(afile)
    with pytest.raises(RunSetupError, match="a part of the path is a file"):
        check_out_dir(afile / "runs")
    check_out_dir(tmp_path / "runs" / "deep")
    assert list((tmp_path / "runs" / "deep").iterdir()) == []  # the probe is gone


def test_os_errors_read_as_one_line() -> None:
    full = OSError(errno.ENOSPC, "No space left on device", "runs/x/replay.html.tmp")
    assert describe_os_error(full, "writing runs/x") == (
        "writing runs/x: no space left on the device (runs/x/replay.html.tmp)")
    ro = OSError(errno.EROFS, "Read-only file system", "runs")
    assert describe_os_error(ro, "--out runs: cannot write there") == (
        "--out runs: cannot write there: the file system is read-only")


def test_a_full_disk_keeps_a_valid_summary_and_leaves_no_temporary_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    run = rd.create_run_dir(tmp_path, "longterm", datetime(2026, 1, 2, 3, 4, 5))
    run.write_config({"experiment": "longterm", "seed": 1, "world": "simple"})
    with ev.EventWriter(run.events, clock=lambda: 0.0) as w:
        w.write(0.0, ev.RUN_START, experiment="longterm", seed=1)
        w.write(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="sentry-duty")
        w.write(9.0, ev.TASK_OUTCOME, task="t1", outcome=ev.FAILED, reason="run ended")
        w.write(9.0, ev.RUN_END, wall_s=1.0, reason="completed")
    from mcap.writer import Writer  # an empty recording: replay.html is built from it

    with run.recording.open("wb") as f:
        recording = Writer(f)
        recording.start()
        recording.finish()
    real_write = pathlib.Path.write_text

    def write_until_full(self: Path, data: str, *args: object, **kw: object) -> int:
        if self.name.endswith(".html.tmp"):  # the big file fills the disk half-way
            real_write(self, data[: len(data) // 2], *args, **kw)  # type: ignore[arg-type]
            raise OSError(errno.ENOSPC, "No space left on device", str(self))
        return real_write(self, data, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(pathlib.Path, "write_text", write_until_full)
    report = build_report(run, replay=True)
    assert report.replay is None
    assert len(report.problems) == 1
    assert report.problems[0].startswith(f"replay not written to {run.replay}:")
    assert "No space left on device" in report.problems[0]
    summary = json.loads(run.summary.read_text())
    assert summary["tasks"]["open_at_end"] == 1
    assert sorted(p.name for p in run.root.iterdir() if p.name.endswith(".tmp")) == []
    assert not run.replay.exists()


def test_watched_runs_are_paced_unless_told_otherwise() -> None:
    from experiments.run_checks import MESHCAT_SPEEDUP, effective_speedup

    assert effective_speedup(None, meshcat=True) == MESHCAT_SPEEDUP == 10.0
    assert effective_speedup(None, meshcat=False) == 0.0
    assert effective_speedup(0.0, meshcat=True) == 0.0
    assert effective_speedup(3.0, meshcat=False) == 3.0


def test_the_live_rate_reaches_the_run_and_a_bad_one_is_refused_naming_the_option(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from click.testing import CliRunner

    from experiments import run_parts
    from experiments.run_checks import LIVE_RATE_HZ
    from experiments.run_cli import run as run_command

    seen = []

    def stop_at_check(settings: run_parts.RunSettings, options: object) -> None:
        seen.append(settings.live_rate_hz)
        raise RunSetupError("stopped before starting")

    monkeypatch.setattr(run_parts, "check_run", stop_at_check)
    for args, want in (([], LIVE_RATE_HZ), (["--live-rate", "1.5"], 1.5)):
        result = CliRunner().invoke(run_command, ["longterm", "--meshcat", *args])
        assert result.exit_code == 2 and "stopped before starting" in result.output
        assert seen.pop() == want
    for bad in ("0", "abc", "100"):
        result = CliRunner().invoke(run_command, ["longterm", "--meshcat", "--live-rate", bad])
        assert result.exit_code == 2 and "--live-rate" in result.output, result.output
    assert seen == []
