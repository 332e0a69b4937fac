"""The TCP front end: listening sockets, non-blocking connections, a selector.

The only module of the server that touches sockets. Every accepted connection becomes a
``Session`` of the core; bytes read are handed to ``core.receive`` and queued output is
written with as few ``send`` calls as possible (whole messages, TCP_NODELAY).
"""

from __future__ import annotations

import contextlib
import logging
import selectors
import socket
from collections.abc import Callable
from dataclasses import dataclass, field

from player_server.server.core import ServerCore, Session
from player_server.server.endpoint import Endpoint

log = logging.getLogger(__name__)

_RECV_SIZE = 256 * 1024


@dataclass(eq=False)
class _Conn:
    sock: socket.socket
    session: Session
    out: memoryview = field(default_factory=lambda: memoryview(b""))
    reading: bool = True
    events: int = selectors.EVENT_READ


class TcpFrontEnd:
    """Listens on one port per endpoint and moves bytes between sockets and the core."""

    def __init__(self, core: ServerCore, host: str = "127.0.0.1", backlog: int = 16) -> None:
        self.core = core
        self.host = host
        self._backlog = backlog
        self._sel = selectors.DefaultSelector()
        self._listeners: list[socket.socket] = []
        self._conns: dict[int, _Conn] = {}
        self._by_session: dict[int, _Conn] = {}
        core.round_ready = self._round_ready
        self._rview = memoryview(bytearray(_RECV_SIZE))
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._sel.register(self._wake_r, selectors.EVENT_READ, ("wake", None))
        self.closed_connections = 0
        self._closed = False

    # -- set-up / tear-down ------------------------------------------------------------------
    def bind(self, endpoints: list[Endpoint]) -> None:
        """Bind and listen on every endpoint's requested port (0 = ephemeral)."""
        try:
            for ep in endpoints:
                ls = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                ls.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                ls.bind((self.host, ep.requested_port))
                ls.listen(self._backlog)
                ls.setblocking(False)
                ep.port = ls.getsockname()[1]
                self._listeners.append(ls)
                self._sel.register(ls, selectors.EVENT_READ, ("listen", ep))
        except OSError:
            self.close()
            raise

    def close(self) -> None:
        """Close every socket (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for conn in list(self._conns.values()):
            self._drop(conn, "server stopping")
        for ls in self._listeners:
            self._sel.unregister(ls)
            ls.close()
        self._listeners.clear()
        with contextlib.suppress(KeyError, ValueError):
            self._sel.unregister(self._wake_r)
        self._wake_r.close()
        self._wake_w.close()
        self._sel.close()

    def wake(self) -> None:
        """Interrupt a blocking ``poll`` from another thread."""
        with contextlib.suppress(OSError):
            self._wake_w.send(b"x")

    @property
    def connections(self) -> int:
        return len(self._conns)

    # -- the loop step ----------------------------------------------------------------------
    def poll(self, timeout_s: float, before_flush: Callable[[], None] | None = None) -> None:
        """Wait up to ``timeout_s`` for I/O, handle it, then flush queued output.

        ``before_flush`` runs after input was handled and before output is written (so
        replies and a round produced in it leave in one write).
        """
        for key, mask in self._sel.select(max(0.0, timeout_s)):
            kind, obj = key.data
            if kind == "listen":
                self._accept(key.fileobj, obj)  # type: ignore[arg-type]
            elif kind == "wake":
                with contextlib.suppress(OSError):
                    self._wake_r.recv(4096)
            else:
                conn: _Conn = obj
                if conn.sock.fileno() < 0:
                    continue
                if mask & selectors.EVENT_READ:
                    self._read(conn)
                if mask & selectors.EVENT_WRITE and conn.sock.fileno() >= 0:
                    self._write(conn)
        if before_flush is not None:
            before_flush()
        self.flush()

    def flush(self) -> None:
        """Write queued output of every connection (without blocking)."""
        for conn in list(self._conns.values()):
            if conn.session.closing is not None:
                self._drop(conn, conn.session.closing)
                continue
            if not conn.out and self.core.has_output(conn.session):
                self._write(conn)
            self._update_interest(conn)

    # -- internals --------------------------------------------------------------------------
    def _accept(self, ls: socket.socket, ep: Endpoint) -> None:
        while True:
            try:
                sock, addr = ls.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                log.warning("accept failed on %s: %s", ep.name, exc)
                return
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            peer = f"{addr[0]}:{addr[1]}"
            session = self.core.open_session(ep, peer)
            # the banner goes out in one blocking send, first (libplayerc reads it in one recv)
            banner = self.core.take_output(session)
            try:
                sock.sendall(banner)
            except OSError:
                self.core.close_session(session)
                sock.close()
                continue
            sock.setblocking(False)
            conn = _Conn(sock, session)
            self._conns[sock.fileno()] = conn
            self._by_session[session.id] = conn
            self._sel.register(sock, selectors.EVENT_READ, ("conn", conn))
            log.info("client %s connected to %s (port %d)", peer, ep.name, ep.port)

    def _read(self, conn: _Conn) -> None:
        view = self._rview
        try:
            # into one buffer allocated once (the core's decoder copies what it keeps)
            n = conn.sock.recv_into(view)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(conn, f"read error: {exc}")
            return
        if not n:
            self._drop(conn, "closed by peer")
            return
        self.core.receive(conn.session, view[:n])
        if conn.session.closing is not None:
            self._drop(conn, conn.session.closing)
        elif not conn.session.round_pending:
            self._write(conn)  # replies leave at once; a pending round joins its ACK later

    def _round_ready(self, session: Session) -> None:
        conn = self._by_session.get(session.id)
        if conn is not None and not conn.out and session.closing is None:
            self._write(conn)

    def _write(self, conn: _Conn) -> None:
        while True:
            if not conn.out:
                if not self.core.has_output(conn.session):
                    return
                conn.out = memoryview(self.core.take_output(conn.session))
            try:
                n = conn.sock.send(conn.out)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                self._drop(conn, f"write error: {exc}")
                return
            conn.out = conn.out[n:]
            if conn.out:
                return

    def _update_interest(self, conn: _Conn) -> None:
        if conn.sock.fileno() < 0:
            return
        want = 0
        if self.core.accepting_input(conn.session):
            want |= selectors.EVENT_READ
        if conn.out or self.core.has_output(conn.session):
            want |= selectors.EVENT_WRITE
        if want != conn.events:
            if want == 0:
                # a client whose replies pile up unread: wait for it to drain
                want = selectors.EVENT_WRITE
            self._sel.modify(conn.sock, want, ("conn", conn))
            conn.events = want

    def _drop(self, conn: _Conn, reason: str) -> None:
        fd = conn.sock.fileno()
        if fd >= 0:
            with contextlib.suppress(KeyError, ValueError):
                self._sel.unregister(conn.sock)
        for k, v in list(self._conns.items()):
            if v is conn:
                del self._conns[k]
        self._by_session.pop(conn.session.id, None)
        conn.sock.close()
        self.core.close_session(conn.session)
        self.closed_connections += 1
        log.info("client %s left %s: %s", conn.session.peer, conn.session.endpoint.name, reason)
