"""The block printed at the end of a run."""

from __future__ import annotations

from pathlib import Path

from experiments import events as ev
from experiments.end_report import end_of_run_lines, next_steps, summary_lines
from experiments.summary import summarize

E = ev.make_event


def _summary() -> dict:
    return summarize([
        E(0.0, ev.RUN_START, experiment="longterm", seed=1),
        E(1.0, ev.TASK_INTRODUCED, task="t1", task_kind="sentry-duty"),
        E(2.0, ev.AWARD, task="t1", robot="p1"),
        E(50.0, ev.TASK_OUTCOME, task="t1", robot="p1", outcome=ev.COMPLETED),
        E(60.0, ev.TASK_INTRODUCED, task="t2", task_kind="cleanup"),
        E(3600.0, ev.TASK_OUTCOME, task="t2", outcome=ev.FAILED, reason="run ended"),
        E(3600.0, ev.RUN_END, wall_s=90.0, reason="completed"),
    ])


def test_the_block_names_every_file_and_what_to_try_next(tmp_path: Path) -> None:
    root = tmp_path / "runs" / "longterm-20260101-000000"
    root.mkdir(parents=True)
    (root / "run.mcap").write_bytes(b"")
    plots = [root / "plots" / "tasks.png", root / "plots" / "battery.png"]
    lines = end_of_run_lines(experiment="longterm", reason="completed", run_root=root,
                             summary=_summary(), plots=plots, replay=root / "replay.html")
    text = "\n".join(lines)
    assert lines[0] == "longterm finished: 1:00:00 simulated"
    assert "executed 1  failed 0  unachievable 0  open at end 1" in text
    assert f"replay         {root / 'replay.html'}" in text
    for p in plots:
        assert str(p) in text
    assert "none drawn" not in text
    assert str(root / "events.jsonl") in text and str(root / "run.mcap") in text
    assert lines.index("next") > lines.index("files")
    assert "murdoch run longterm --until 1h --kill p3@30m --restart p3@45m" in text


def test_an_interrupted_run_says_so_and_lists_what_failed_to_write() -> None:
    lines = end_of_run_lines(experiment="boxpush", reason="interrupted", run_root=Path("r"),
                             summary=_summary(), plots=[], replay=None,
                             problems=["replay not written to r/replay.html: No space left"])
    assert lines[0] == "interrupted at 1:00:00 simulated; what was recorded so far:"
    assert "error: replay not written to r/replay.html: No space left" in lines
    assert not any(line.strip().startswith("replay ") for line in lines)
    assert "  plots          none drawn (murdoch report r draws them)" in lines


def test_summary_lines_and_next_steps() -> None:
    lines = summary_lines(_summary())
    assert lines[0] == "sim time   1:00:00 simulated in 0:01:30 wall, real-time factor 40.0"
    assert lines[-1].endswith("yes")
    assert any("switch-off" in s for s in next_steps("boxpush", Path("r")))
