"""`murdoch compare longterm --dask`: the runs on a real Dask cluster bound to 127.0.0.1, the
same rows as the thread pool's; a bad, unreachable or missing Dask is named."""

from __future__ import annotations

import csv
import json
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from experiments.cli import main
from experiments.compare import COLUMNS
from murdoch import dask_jobs

distributed = pytest.importorskip("distributed",
                                  reason="the dask extra (distributed) is not installed")
pytestmark = pytest.mark.timeout(600)

TINY = ["compare", "longterm", "--allocators", "murdoch", "--seeds", "1-2", "--until", "2m",
        "--task-interval", "40", "--no-plots"]
"""Two short runs of MURDOCH (seeds 1 and 2), without plots of their own."""
DIFFER = {"wall_time_s", "run_dir"}
"""The only columns that may differ between two runs of the same job."""


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def _compare(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*_murdoch(), *args], capture_output=True, text=True, timeout=560,
                          check=False)


def _rows(out: Path) -> list[dict[str, str]]:
    with (out / "comparison.csv").open() as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        yield address


@pytest.fixture
def closed_port() -> Iterator[int]:
    """A port on 127.0.0.1 held by a socket that never listens: connecting to it is refused."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


def test_the_cluster_gives_the_thread_pools_rows(scheduler: str, tmp_path: Path) -> None:
    pool, dask = tmp_path / "pool", tmp_path / "dask"
    in_pool = _compare(*TINY, "--jobs", "2", "--out", str(pool))
    assert in_pool.returncode == 0, in_pool.stdout[-2000:] + in_pool.stderr[-2000:]
    on_dask = _compare(*TINY, "--dask", scheduler, "--out", str(dask))
    assert on_dask.returncode == 0, on_dask.stdout[-2000:] + on_dask.stderr[-2000:]
    assert f"on the Dask cluster at {scheduler}" in on_dask.stdout
    assert "murdoch (2 runs)" in on_dask.stdout
    pool_rows, dask_rows = _rows(pool), _rows(dask)
    assert list(dask_rows[0]) == list(COLUMNS)
    assert [(r["allocator"], r["seed"]) for r in dask_rows] == [("murdoch", "1"),
                                                                ("murdoch", "2")]
    for p, d in zip(pool_rows, dask_rows, strict=True):
        assert d["exit_code"] == "0" and d["error"] == ""
        # in lockstep a run is a pure function of its world, seed and options
        assert len(d["events_sha256"]) == 64 and d["events_sha256"] == p["events_sha256"]
        assert ({k: v for k, v in d.items() if k not in DIFFER}
                == {k: v for k, v in p.items() if k not in DIFFER})
        run = Path(d["run_dir"])  # the workers share this filesystem here
        assert run.parent.parent == dask
        summary = json.loads((run / "summary.json").read_text())
        assert summary["events_sha256"] == d["events_sha256"]
    assert pool_rows[0]["events_sha256"] != pool_rows[1]["events_sha256"]
    png = dask / "comparison.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_bad_address_or_jobs_with_dask_is_refused_before_anything_runs(
        tmp_path: Path) -> None:
    for args, needles in ((["--dask", "127.0.0.1:8786"], ("--dask", "tcp://HOST:PORT")),
                          (["--dask", "tcp://127.0.0.1"], ("--dask", "tcp://HOST:PORT")),
                          (["--dask", "tcp://127.0.0.1:8786", "--jobs", "3"],
                           ("--jobs", "got 3"))):
        proc = _compare(*TINY, *args, "--out", str(tmp_path / "c"))
        assert proc.returncode == 2, (args, proc.stdout, proc.stderr)
        assert all(n in proc.stderr for n in needles) and "Traceback" not in proc.stderr
    assert not list(tmp_path.iterdir())


def test_an_unreachable_scheduler_is_named_within_the_connect_timeout(
        closed_port: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dask_jobs, "CONNECT_TIMEOUT_S", 2.0)
    address = f"tcp://127.0.0.1:{closed_port}"
    r = CliRunner().invoke(main, [*TINY, "--dask", address, "--out", str(tmp_path / "c")])
    assert r.exit_code == 1, r.output
    assert f"cannot reach the Dask scheduler at {address}" in r.output
    assert isinstance(r.exception, SystemExit)  # a message, not a traceback
    assert not (tmp_path / "c").exists()


def test_without_distributed_the_extra_to_install_is_named(closed_port: int,
                                                           tmp_path: Path) -> None:
    hide = ("import sys; sys.modules['distributed'] = None; "
            "from experiments.cli import main; sys.exit(main())")
    proc = subprocess.run([sys.executable, "-c", hide, *TINY, "--dask",
                           f"tcp://127.0.0.1:{closed_port}", "--out", str(tmp_path / "c")],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "pip install 'murdoch[dask]'" in proc.stderr and "Traceback" not in proc.stderr
