"""`murdoch sweep --dask`: the sweep's jobs on a real Dask cluster bound to 127.0.0.1."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from experiments.cli import main
from murdoch.consensus.experiments import RunRecord
from murdoch.consensus.sweep import jobs_for, run_jobs

distributed = pytest.importorskip("distributed",
                                  reason="the dask extra (distributed) is not installed")
pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        yield address


def _without_times(records: list[RunRecord]) -> list[dict[str, object]]:
    return [{k: v for k, v in dataclasses.asdict(r).items() if k != "solve_s"} for r in records]


def test_the_cluster_gives_the_process_pools_records_in_the_same_order(scheduler: str) -> None:
    jobs = [*jobs_for("fig5", (1, 2, 3), 2, seed=11), *jobs_for("fig7", (4,), 2, seed=11)]
    seen: list[int] = []
    on_dask = run_jobs(jobs, 1, lambda done, total: seen.append(done), dask_address=scheduler)
    in_pool = run_jobs(jobs, 2)
    assert _without_times(on_dask) == _without_times(in_pool)
    assert len(on_dask) == len(jobs) and seen[-1] == len(jobs)
    assert all(r.solve_s > 0 for r in on_dask)


def test_sweep_dask_writes_the_same_table(scheduler: str, tmp_path: Path) -> None:
    outs = {}
    for name, extra in (("pool", ["--jobs", "1"]), ("dask", ["--dask", scheduler])):
        out = tmp_path / name
        r = CliRunner().invoke(main, ["sweep", "--experiment", "fig5", "--agents", "1-2",
                                      "--runs", "2", "--seed", "4", "--out", str(out), *extra])
        assert r.exit_code == 0, r.output
        outs[name] = json.loads((out / "summary.json").read_text())
    strip = [{k: v for k, v in row.items() if k != "solve_ms_mean"}
             for row in outs["pool"]["rows"]]
    assert strip == [{k: v for k, v in row.items() if k != "solve_ms_mean"}
                     for row in outs["dask"]["rows"]]
    assert outs["dask"]["meta"]["dask"] == scheduler


def test_a_bad_or_unreachable_scheduler_is_named(tmp_path: Path) -> None:
    r = CliRunner().invoke(main, ["sweep", "--agents", "1", "--runs", "1",
                                  "--out", str(tmp_path / "x"), "--dask", "127.0.0.1:8786"])
    assert r.exit_code == 2 and "tcp://HOST:PORT" in r.output
