"""Jobs on a Dask cluster (optional: ``pip install 'murdoch[dask]'``).

`murdoch sweep --dask tcp://HOST:PORT` and `murdoch compare longterm --dask tcp://HOST:PORT`
send the jobs they would otherwise run on this machine to the workers of the Dask scheduler
at that address and take the results back in job order. `check_address` is the one rule for
what an address looks like; `connected` opens (and always closes) a client and hands out a
`submit` for jobs, each its own task, never taken from a cache; `run_in_order` runs one
function over a list of items with it. The workers need this package installed (the same
version).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Protocol, TypeVar

_ADDRESS = re.compile(r"^(tcp|tls)://[^\s/:]+:[0-9]{1,5}$")

CONNECT_TIMEOUT_S = 30.0
"""How long a client waits for the scheduler before giving up (when not told otherwise)."""

T = TypeVar("T")
R = TypeVar("R")


class DaskUnavailable(RuntimeError):
    """The optional `distributed` package is not installed."""


class Submit(Protocol):
    """Sends `fn(arg)` to a worker; its future (whose `result()` waits for it)."""

    def __call__(self, fn: Callable[[Any], Any], arg: Any, /) -> Any: ...


def check_address(address: str) -> str:
    """`address` if it looks like a scheduler address, else ValueError saying what is expected."""
    if not _ADDRESS.match(address):
        raise ValueError(f"{address!r} is not a Dask scheduler address: expected "
                         "tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786)")
    return address


@contextmanager
def connected(address: str, prepare: Callable[[], None] | None = None,
              connect_timeout_s: float | None = None) -> Iterator[Submit]:
    """A client of the scheduler at `address`, as a `submit`; `prepare` runs once on every
    worker first. DaskUnavailable without `distributed`; OSError (naming the address) when
    the scheduler does not answer within `connect_timeout_s` (default `CONNECT_TIMEOUT_S`)."""
    check_address(address)
    try:
        from distributed import Client
    except ImportError:
        raise DaskUnavailable("--dask needs the distributed package: pip install "
                              "'murdoch[dask]'") from None
    timeout = CONNECT_TIMEOUT_S if connect_timeout_s is None else connect_timeout_s
    try:
        client = Client(address, timeout=f"{timeout:g}s")
    except OSError as exc:
        raise OSError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    try:
        if prepare is not None:
            client.run(prepare)

        def submit(fn: Callable[[Any], Any], arg: Any, /) -> Any:
            return client.submit(fn, arg, pure=False)

        yield submit
    finally:
        client.close()


def run_in_order(address: str, fn: Callable[[T], R], items: Sequence[T],
                 prepare: Callable[[], None] | None = None,
                 on_result: Callable[[R], None] | None = None,
                 connect_timeout_s: float | None = None) -> list[R]:
    """`fn` of every item on the cluster at `address`, all sent at once; the results in item
    order (`on_result` sees each as it is taken). The first job that raised raises here."""
    with connected(address, prepare, connect_timeout_s) as submit:
        futures = [submit(fn, item) for item in items]
        out: list[R] = []
        for future in futures:
            result: R = future.result()
            out.append(result)
            if on_result is not None:
                on_result(result)
        return out
