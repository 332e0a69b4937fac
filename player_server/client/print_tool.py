"""``player-print <interface>``: print a device's data, like Player's ``playerprint``.

Options follow Player's habits: ``-h`` host, ``-p`` port, ``-i`` index, ``-c`` count
(0 = forever); ``--help`` for help. The client asks not to hold a lockstep server's clock.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable
from typing import Any

from player_server.client.connection import PlayerClient
from player_server.client.errors import PlayerConnectionError, PlayerError
from player_server.client.proxies import PROXIES
from player_server.client.proxy import Proxy
from player_server.protocol.constants import DEFAULT_PORT, interface_name


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3f}"
    if isinstance(value, bytes):
        return value.hex() if len(value) <= 32 else f"<{len(value)} bytes>"
    if isinstance(value, tuple):
        return "[" + " ".join(_fmt(v) for v in value) + "]"
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return "{" + ", ".join(f"{f.name}={_fmt(getattr(value, f.name))}"
                               for f in dataclasses.fields(value)) + "}"
    return str(value)


def latest(proxy: Proxy) -> Any:
    """The proxy's latest data body (or its list-valued field)."""
    for attr in ("state", "scan", "state_data"):
        body = getattr(proxy, attr, None)
        if body is not None and dataclasses.is_dataclass(body):
            return body
    for attr in ("ranges", "bumpers", "fiducials"):
        if hasattr(proxy, attr):
            return {attr: getattr(proxy, attr)}
    return {}


def render(proxy: Proxy) -> str:
    name = interface_name(proxy.interf)
    lines = [f"#{name}({proxy.interf}:{proxy.index}) - {proxy.data_time_s:.3f}"]
    body = latest(proxy)
    items = (
        [(f.name, getattr(body, f.name)) for f in dataclasses.fields(body)]
        if dataclasses.is_dataclass(body) and not isinstance(body, type)
        else list(body.items())
    )
    for key, value in items:
        if isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
            lines.append(f"{key}: {len(value)}")
            lines += [f"  {_fmt(v)}" for v in value]
        else:
            lines.append(f"{key}: {_fmt(value)}")
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="player-print", add_help=False,
                                description="Print the data of one Player device.")
    p.add_argument("--help", action="help", help="show this help and exit")
    p.add_argument("-h", dest="host", default="127.0.0.1", help="host (default %(default)s)")
    p.add_argument("-p", dest="port", type=int, default=DEFAULT_PORT,
                   help="port (default %(default)s)")
    p.add_argument("-i", dest="index", type=int, default=0, help="device index (default 0)")
    p.add_argument("-c", dest="count", type=int, default=0,
                   help="stop after this many prints (default 0 = forever)")
    p.add_argument("-t", dest="timeout", type=float, default=10.0,
                   help="seconds to wait for the server to listen and for data "
                        "(default %(default)s)")
    p.add_argument("interface", choices=sorted(k for k in PROXIES if k != "simulation"),
                   help="interface name")
    return p


def connect_when_up(client: PlayerClient, timeout_s: float, period_s: float = 0.2,
                    clock: Callable[[], float] = time.monotonic,
                    sleep: Callable[[float], None] = time.sleep) -> None:
    """Connect, retrying while nothing listens on the port yet (a server still starting, as
    in ``player-server simple & player-print -p 6665 laser``) until `timeout_s` has passed."""
    deadline = clock() + timeout_s
    while True:
        try:
            client.connect()
            return
        except PlayerConnectionError as exc:
            refused = isinstance(exc.__cause__, ConnectionRefusedError)
            if not refused or clock() + period_s > deadline:
                raise
        sleep(period_s)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    client = PlayerClient(args.host, args.port, timeout_s=args.timeout,
                          read_timeout_s=args.timeout, lockstep=False)
    try:
        connect_when_up(client, args.timeout)
        proxy = client.subscribe(PROXIES[args.interface], args.index)
        printed = 0
        while args.count <= 0 or printed < args.count:
            client.read()
            print(render(proxy), flush=True)
            printed += 1
    except KeyboardInterrupt:
        pass
    except PlayerError as exc:
        print(f"player-print: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        pass
    finally:
        client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
