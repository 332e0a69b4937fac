"""Running a sweep's jobs on a Dask cluster (optional: ``pip install 'murdoch[dask]'``).

`murdoch sweep --dask tcp://HOST:PORT` sends the same chunks of jobs the process pool would
run to the workers of the Dask scheduler at that address and gathers the records in the
same order. Each job's seed is in the job (`murdoch.consensus.sweep.Job`), so the records
are the pool's, except for the measured solve times. Workers need this package installed
(the same version); before the jobs go out, every worker loads the compiled runs they use,
outside the solve times it records.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import Any

from murdoch.consensus.experiments import RunRecord

_ADDRESS = re.compile(r"^(tcp|tls)://[^\s/:]+:[0-9]{1,5}$")


class DaskUnavailable(RuntimeError):
    """The optional `distributed` package is not installed."""


def check_address(address: str) -> str:
    """`address` if it looks like a scheduler address, else ValueError saying what is expected."""
    if not _ADDRESS.match(address):
        raise ValueError(f"{address!r} is not a Dask scheduler address: expected "
                         "tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786)")
    return address


def run_chunks_on_dask(
    address: str,
    chunks: Sequence[Any],
    run_chunk: Callable[[Any], list[RunRecord]],
    prepare: Callable[[], None],
    progress: Callable[[int], None] | None = None,
    connect_timeout_s: float = 30.0,
) -> list[list[RunRecord]]:
    """Run `run_chunk` on every chunk on the cluster at `address`; results in chunk order.
    `prepare` runs once on every worker first."""
    check_address(address)
    try:
        from distributed import Client
    except ImportError:
        raise DaskUnavailable("--dask needs the distributed package: pip install "
                              "'murdoch[dask]'") from None
    try:
        client = Client(address, timeout=f"{connect_timeout_s}s")
    except OSError as exc:
        raise OSError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    try:
        client.run(prepare)
        futures = client.map(run_chunk, list(chunks), pure=False)
        out = []
        for future in futures:
            records = future.result()
            out.append(records)
            if progress is not None:
                progress(len(records))
        return out
    finally:
        client.close()
