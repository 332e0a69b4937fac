"""Which finished runs `murdoch compare --resume` reuses (pure rules and the directory)."""

from __future__ import annotations

import json
from pathlib import Path

from experiments.compare_resume import expected_config, mismatch, reusable_run


def _expected(group_tasks: float = 0.2, **over: object) -> dict[str, object]:
    base: dict[str, object] = dict(allocator="cbga", refine=False, seed=3, until_s=600.0,
                                   task_interval_s=240.0, kills=["busy@2m"],
                                   restarts=["busy@4m"], world=None,
                                   own={"group_task_rate": group_tasks} if group_tasks else {})
    base.update(over)
    return expected_config(**base)  # type: ignore[arg-type]


def _config(**over: object) -> dict[str, object]:
    config: dict[str, object] = {
        "experiment": "longterm", "allocator": "cbga", "refine": False, "seed": 3,
        "duration_s": 600, "task_interval_s": 240.0, "group_task_rate": 0.2,
        "kills": ["busy@2m"], "restarts": ["busy@4m"], "world": "longterm",
        "lockstep": True, "team_key": "fresh"}
    config.update(over)
    return config


def test_a_run_with_the_same_options_is_reused() -> None:
    assert mismatch(_config(), {"end_reason": "completed"}, _expected()) is None
    plain = _config(group_task_rate=None)  # a run without group tasks names no rate
    assert mismatch(plain, {"end_reason": "completed"}, _expected(group_tasks=0.0)) is None


def test_any_other_option_or_an_unfinished_run_is_made_again() -> None:
    done = {"end_reason": "completed"}
    assert "seed is 4" in str(mismatch(_config(seed=4), done, _expected()))
    assert "group_task_rate" in str(mismatch(_config(group_task_rate=0.0), done, _expected()))
    assert "kills" in str(mismatch(_config(kills=[]), done, _expected()))
    assert "refine" in str(mismatch(_config(refine=True), done, _expected()))
    assert "world" in str(mismatch(_config(), done, _expected(world="swarm100")))
    assert "lockstep" in str(mismatch(_config(lockstep=False), done, _expected()))
    assert "ended 'error'" in str(mismatch(_config(), {"end_reason": "error"}, _expected()))


def test_the_newest_run_directory_is_the_one_judged(tmp_path: Path) -> None:
    label = tmp_path / "cbga-s3"
    assert reusable_run(label, _expected()) == (None, "no run yet")
    old, new = label / "longterm-20261201-100000", label / "longterm-20261201-110000"
    for run, seed in ((old, 3), (new, 5)):
        run.mkdir(parents=True)
        (run / "config.json").write_text(json.dumps(_config(seed=seed)))
        (run / "summary.json").write_text(json.dumps({"end_reason": "completed"}))
    run, why = reusable_run(label, _expected())
    assert run is None and "seed is 5" in why
    (new / "summary.json").unlink()
    run, why = reusable_run(label, _expected(seed=5))
    assert run is None and "did not finish" in why
