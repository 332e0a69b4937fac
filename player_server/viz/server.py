"""Owner of the meshcat viewer process and the ZeroMQ channel that feeds it.

`ViewerProcess` starts ``python -m player_server.viz.bridge`` (loopback only), reads the two
URLs it prints and stops it. `ZmqChannel` sends viewer commands to it with bounded waits, so
a dead or stuck viewer can never block the caller for long.
"""

from __future__ import annotations

import logging
import os
import selectors
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import umsgpack
import zmq

from player_server.children import end_child

log = logging.getLogger(__name__)


class ViewerUnavailable(RuntimeError):
    """The viewer did not answer in time (or has gone)."""


@dataclass(frozen=True, slots=True)
class ViewerUrls:
    zmq_url: str
    web_url: str


class ViewerProcess:
    """The meshcat bridge as a child process. Use as a context manager or call `stop()`."""

    def __init__(
        self,
        *,
        web_port: int = 0,
        zmq_port: int = 0,
        start_timeout_s: float = 60.0,
        python: str = sys.executable,
    ) -> None:
        # the bridge exits by itself when this process is gone, however it ended
        args = [python, "-u", "-m", "player_server.viz.bridge",
                "--web-port", str(web_port), "--zmq-port", str(zmq_port),
                "--parent-pid", str(os.getpid())]
        self._proc = subprocess.Popen(
            args,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            self.urls = self._read_urls(start_timeout_s)
        except BaseException:
            self.stop()
            raise

    @property
    def pid(self) -> int:
        return self._proc.pid

    def _read_urls(self, timeout_s: float) -> ViewerUrls:
        assert self._proc.stdout is not None
        found: dict[str, str] = {}
        buffer = b""
        with selectors.DefaultSelector() as sel:
            sel.register(self._proc.stdout, selectors.EVENT_READ)
            # each select waits at most timeout_s; the line count bounds the loop
            for _ in range(64):
                if "zmq_url" in found and "web_url" in found:
                    return ViewerUrls(found["zmq_url"], found["web_url"])
                if not sel.select(timeout_s):
                    break
                chunk = self._proc.stdout.read1(4096)  # type: ignore[attr-defined]
                if not chunk:
                    break
                buffer += chunk
                *lines, buffer = buffer.split(b"\n")
                for line in lines:
                    key, _, value = line.decode("utf-8", "replace").strip().partition("=")
                    if key in ("zmq_url", "web_url"):
                        found[key] = value
        raise RuntimeError(
            f"the meshcat viewer process did not report its URLs (exit code {self._proc.poll()})"
        )

    def alive(self) -> bool:
        return self._proc.poll() is None

    def stop(self, timeout_s: float = 5.0) -> None:
        end_child(self._proc, timeout_s)
        if self._proc.stdout is not None:
            self._proc.stdout.close()

    def __enter__(self) -> ViewerProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class ZmqChannel:
    """Sends meshcat commands (plain dicts) to a viewer over ZeroMQ REQ/REP.

    Every send waits at most `timeout_s` for the viewer's reply; on a timeout the socket is
    rebuilt (a REQ socket that missed a reply cannot be reused) and `ViewerUnavailable` raised.
    Not thread-safe: one owner thread sends.
    """

    def __init__(self, zmq_url: str, *, timeout_s: float = 2.0,
                 context_factory: Callable[[], Any] = zmq.Context) -> None:
        if not zmq_url.startswith("tcp://127.0.0.1:") and not zmq_url.startswith("ipc://"):
            raise ValueError(f"refusing to send viewer commands off this host: {zmq_url!r}")
        self._url = zmq_url
        self._timeout_ms = max(1, int(timeout_s * 1000))
        self._context = context_factory()
        self._socket: Any = None
        self.commands_sent = 0
        self.bytes_sent = 0
        self._connect()

    def _connect(self) -> None:
        if self._socket is not None:
            self._socket.close(linger=0)
        sock = self._context.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, self._timeout_ms)
        sock.setsockopt(zmq.SNDTIMEO, self._timeout_ms)
        sock.connect(self._url)
        self._socket = sock

    def send(self, command: dict[str, Any]) -> None:
        payload = umsgpack.packb(command, force_float_precision="single")
        frames = [command["type"].encode("utf-8"), command.get("path", "").encode("utf-8"), payload]
        try:
            self._socket.send_multipart(frames)
            reply = self._socket.recv()
        except zmq.Again as exc:
            self._connect()
            raise ViewerUnavailable(f"no reply from the viewer at {self._url}") from exc
        if reply != b"ok":
            log.warning("viewer refused %s %s: %r", command["type"], command.get("path"), reply)
        self.commands_sent += 1
        self.bytes_sent += len(payload)

    def close(self) -> None:
        if self._socket is not None:
            self._socket.close(linger=0)
            self._socket = None
        self._context.term()
