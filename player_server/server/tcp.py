"""The TCP front end: listening sockets, non-blocking connections, a selector.

The only module of the server that touches sockets. Every accepted connection becomes a
``Session`` of the core; bytes read are handed to ``core.receive`` and queued output is
written with as few ``send`` calls as possible (whole messages, TCP_NODELAY).

A receive that sends nothing back at once (a command) is followed by TCP_QUICKACK (Linux):
a client that leaves Nagle's algorithm on (as libplayerc does) and sends a command, which
gets no reply, then a request would otherwise wait for the server's delayed ACK (~40 ms)
before the request leaves it. A reply sent at once carries the ACK itself, and so does a
PULL round that a REQ DATA left pending (the client waits for it anyway): neither needs
that system call.

Against hostile clients: at most ``max_connections`` at once (more are closed at accept); a
client whose input exceeds its per-turn budget is not read again until the core has worked
through it; a frame not completed within ``frame_timeout_s`` closes its connection; when
``accept`` fails for want of file handles the listeners rest for a while (backing off up to
``_ACCEPT_BACKOFF_MAX_S``) instead of spinning.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import math
import select
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass

from player_server.server.core import ServerCore, Session
from player_server.server.endpoint import Endpoint
from player_server.server.log_limit import LogLimiter
from player_server.server.session import connection_cap

log = logging.getLogger(__name__)

_RECV_SIZE = 256 * 1024
_QUICKACK = getattr(socket, "TCP_QUICKACK", None)
#: accept errors that mean "no resources now": rest the listeners instead of spinning
_ACCEPT_EXHAUSTED = {errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM}
_ACCEPT_BACKOFF_MIN_S = 0.05
_ACCEPT_BACKOFF_MAX_S = 2.0
#: how often connections are checked for frames left incomplete too long
_FRAME_CHECK_S = 0.5
_IN = select.EPOLLIN
_OUT = select.EPOLLOUT


@dataclass(eq=False)
class _Conn:
    sock: socket.socket
    session: Session
    #: bytes taken from the session's queue and not yet sent
    out: bytes | memoryview = b""
    reading: bool = True
    #: the epoll events the connection is registered for
    events: int = _IN
    #: (clock, messages decoded) when bytes of an incomplete frame were first seen waiting
    partial: tuple[float, int] | None = None


class TcpFrontEnd:
    """Listens on one port per endpoint and moves bytes between sockets and the core."""

    def __init__(self, core: ServerCore, host: str = "127.0.0.1", backlog: int = 16,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.core = core
        self.host = host
        self._backlog = backlog
        self._clock = clock
        self._limiter = LogLimiter(log, clock=clock)
        self._conn_log = LogLimiter(log, burst=50, clock=clock)
        #: listeners rest until this time after accept ran out of file handles
        self._accept_resume: float | None = None
        self._accept_backoff = _ACCEPT_BACKOFF_MIN_S
        self._next_frame_check = 0.0
        #: frames are timed at all (the core's configuration is frozen)
        self._frames_timed = core.config.frame_timeout_s > 0
        self.refused_connections = 0
        self.accept_failures = 0
        self.frame_timeouts = 0
        # a bare epoll and file descriptor -> connection maps: a selector's key objects per
        # event cost more than a round trip's own work
        self._ep = select.epoll()
        self._listeners: list[socket.socket] = []
        self._listener_eps: list[Endpoint] = []
        #: listening socket's descriptor -> (socket, endpoint), while accepting
        self._listening: dict[int, tuple[socket.socket, Endpoint]] = {}
        self._conns: dict[int, _Conn] = {}
        self._by_session: dict[int, _Conn] = {}
        #: connections whose last turn left input to handle (``core.has_backlog``)
        self._backlogged: list[_Conn] = []
        #: connections a poll read, wrote or worked on: the ones its flush looks at
        self._touched: list[_Conn] = []
        core.round_ready = self._round_ready
        self._rview = memoryview(bytearray(_RECV_SIZE))
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._wake_fd = self._wake_r.fileno()
        self._ep.register(self._wake_fd, _IN)
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
                self._listener_eps.append(ep)
                self._listen(ls, ep)
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
        self._stop_listening()
        for ls in self._listeners:
            ls.close()
        self._listeners.clear()
        with contextlib.suppress(OSError, ValueError):
            self._ep.unregister(self._wake_fd)
        self._wake_r.close()
        self._wake_w.close()
        self._ep.close()

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
        replies and a round produced in it leave in one write). Only the connections this
        poll read, wrote or worked on are flushed, unless a round was published meanwhile
        (every connection may then have output): a request costs the same whatever the
        number of other connections.
        """
        if self._accept_resume is not None:
            self._resume_accepting()
        if self._backlogged:
            timeout_s = 0.0  # input waits to be handled: just look for more I/O
        elif self._accept_resume is not None:
            timeout_s = min(timeout_s, max(0.0, self._accept_resume - self._clock()))
        # whole milliseconds, rounded up (as selectors does): no busy wait below one
        timeout_s = math.ceil(timeout_s * 1e3) * 1e-3 if timeout_s > 0 else 0.0
        touched = self._touched
        conns = self._conns
        for fd, ev in self._ep.poll(timeout_s):
            conn = conns.get(fd)
            if conn is None:
                self._other_event(fd)
                continue
            # an error or hang-up counts as both readable and writable, for what the
            # connection waits for (as selectors has it)
            if ev & ~_OUT and conn.events & _IN:
                self._read(conn)
            if ev & ~_IN and conn.events & _OUT and conn.sock.fileno() >= 0:
                self._write(conn)
                self._settle(conn)
        if self._backlogged:
            self._work_backlogs()
        if self._frames_timed:
            now = self._clock()
            if now >= self._next_frame_check:
                self._check_frames(now)
        core = self.core
        seq = core.round_seq
        if before_flush is not None:
            before_flush()
        if core.round_seq != seq:
            touched.clear()
            self.flush()
        elif touched:
            self._flush_conns(touched)
            touched.clear()

    def _other_event(self, fd: int) -> None:
        """A listening socket or the wake-up socket is readable."""
        if fd == self._wake_fd:
            with contextlib.suppress(OSError):
                self._wake_r.recv(4096)
            return
        listening = self._listening.get(fd)
        if listening is not None:
            self._accept(*listening)

    def flush(self) -> None:
        """Write queued output of every connection (without blocking)."""
        self._flush_conns(list(self._conns.values()))

    def _flush_conns(self, conns: list[_Conn]) -> None:
        for conn in conns:
            if conn.sock.fileno() < 0:
                continue  # dropped meanwhile
            if conn.session.closing is not None:
                self._drop(conn, conn.session.closing, abort=True)
                continue
            if not conn.out:
                self._write(conn)
            self._update_interest(conn)

    def _settle(self, conn: _Conn) -> None:
        """After a connection's own ``_write``: close it if its session ended, else wait
        for what it now needs. The write left bytes in ``conn.out`` if, and only if, the
        socket did not take all of its queue."""
        if conn.sock.fileno() < 0:
            return
        session = conn.session
        if session.closing is not None:
            self._drop(conn, session.closing, abort=True)
            return
        want = _IN if self.core.accepting_input(session) else 0
        if conn.out:
            want |= _OUT
        if want != conn.events:
            self._set_interest(conn, want)

    # -- limits ---------------------------------------------------------------------------
    def _work_backlogs(self) -> None:
        """Give every client with input left over from its last turn another budget."""
        waiting, self._backlogged = self._backlogged, []
        for conn in waiting:
            if conn.sock.fileno() < 0 or not self.core.has_backlog(conn.session):
                continue
            self._touched.append(conn)
            self.core.process(conn.session)
            if conn.session.closing is not None:
                self._drop(conn, conn.session.closing, abort=True)
                continue
            if conn.session.backlog:
                self._backlogged.append(conn)
            if not conn.session.round_pending:
                self._write(conn)

    def _check_frames(self, now: float) -> None:
        """Close connections that left a frame incomplete for longer than allowed (called
        when the check is due)."""
        limit = self.core.config.frame_timeout_s
        self._next_frame_check = now + _FRAME_CHECK_S
        for conn in list(self._conns.values()):
            dec = conn.session.decoder
            if dec.buffered == 0 or self.core.has_backlog(conn.session):
                conn.partial = None
                continue
            if conn.partial is None or conn.partial[1] != dec.messages + dec.undecodable:
                conn.partial = (now, dec.messages + dec.undecodable)
            elif now - conn.partial[0] > limit:
                self.frame_timeouts += 1
                reason = (f"a frame stayed incomplete for more than {limit:g} s "
                          f"({dec.buffered} bytes waiting)")
                self._limiter.log("frame timeout", logging.WARNING, "closing client %s on %s: %s",
                                  conn.session.peer, conn.session.endpoint.name, reason)
                self._drop(conn, reason, abort=True)

    def _rest_listeners(self, ep: Endpoint, exc: OSError) -> None:
        """accept ran out of resources: stop listening for a while (doubling the pause)."""
        self.accept_failures += 1
        self._limiter.log("accept", logging.WARNING,
                          "accept failed on %s: %s; not accepting for %.2f s", ep.name, exc,
                          self._accept_backoff)
        self._stop_listening()
        self._accept_resume = self._clock() + self._accept_backoff
        self._accept_backoff = min(self._accept_backoff * 2.0, _ACCEPT_BACKOFF_MAX_S)

    def _resume_accepting(self) -> None:
        if self._accept_resume is None or self._clock() < self._accept_resume or self._closed:
            return
        self._accept_resume = None
        for ls, ep in zip(self._listeners, self._listener_eps, strict=True):
            self._listen(ls, ep)

    def _listen(self, ls: socket.socket, ep: Endpoint) -> None:
        fd = ls.fileno()
        if fd >= 0 and fd not in self._listening:
            self._ep.register(fd, _IN)
            self._listening[fd] = (ls, ep)

    def _stop_listening(self) -> None:
        for fd in list(self._listening):
            with contextlib.suppress(OSError, ValueError):
                self._ep.unregister(fd)
        self._listening.clear()

    # -- internals --------------------------------------------------------------------------
    def _accept(self, ls: socket.socket, ep: Endpoint) -> None:
        while True:
            try:
                sock, addr = ls.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                if exc.errno in _ACCEPT_EXHAUSTED:
                    self._rest_listeners(ep, exc)
                else:
                    self._limiter.log("accept", logging.WARNING, "accept failed on %s: %s",
                                      ep.name, exc)
                return
            self._accept_backoff = _ACCEPT_BACKOFF_MIN_S
            if len(self._conns) >= connection_cap(self.core.config, len(self._listener_eps)):
                self.refused_connections += 1
                self._limiter.log("connection cap", logging.WARNING,
                                  "refused a connection from %s:%s to %s: %d connections "
                                  "already open (the limit)", addr[0], addr[1], ep.name,
                                  len(self._conns))
                sock.close()
                continue
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
            self._ep.register(sock.fileno(), _IN)
            self._conn_log.log("connect", logging.INFO, "client %s connected to %s (port %d)",
                               peer, ep.name, ep.port)

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
        session = conn.session
        self.core.receive(session, view[:n])
        if session.closing is not None:
            self._drop(conn, session.closing, abort=True)
            return
        if session.round_pending:
            # its ACK leaves with the round, and the client waits for that anyway; what
            # is still queued after this poll's rounds leaves in its flush
            self._touched.append(conn)
            if session.backlog:
                self._backlogged.append(conn)
            return
        if not self._write(conn) and _QUICKACK is not None:  # replies leave at once
            # nothing went back to carry the TCP ACK: acknowledge now, not after the
            # delayed-ACK timer (a Nagle client's next message waits for this ACK)
            with contextlib.suppress(OSError):
                conn.sock.setsockopt(socket.IPPROTO_TCP, _QUICKACK, 1)
        if session.backlog:
            # the rest of its input is handled later in this poll, then it is flushed
            self._backlogged.append(conn)
            self._touched.append(conn)
        else:
            self._settle(conn)

    def _round_ready(self, session: Session) -> None:
        conn = self._by_session.get(session.id)
        if conn is not None and not conn.out and session.closing is None:
            self._write(conn)

    def _write(self, conn: _Conn) -> bool:
        """Send what the connection has queued, without blocking; True if bytes left.

        What the socket did not take stays in ``conn.out`` (and the connection then waits
        until it can write)."""
        sent = False
        out = conn.out
        core = self.core
        session = conn.session
        send = conn.sock.send
        while True:
            if not out:
                out = core.take_output(session)
                if not out:
                    conn.out = out
                    return sent
            try:
                n = send(out)
            except (BlockingIOError, InterruptedError):
                conn.out = out
                return sent
            except OSError as exc:
                conn.out = b""
                self._drop(conn, f"write error: {exc}")
                return sent
            sent = sent or n > 0
            if n < len(out):
                conn.out = memoryview(out)[n:]
                return sent
            out = b""
            if not core.has_output(session):
                conn.out = out
                return sent

    def _update_interest(self, conn: _Conn) -> None:
        if conn.sock.fileno() < 0:
            return
        want = 0
        if self.core.accepting_input(conn.session):
            want |= _IN
        if conn.out or self.core.has_output(conn.session):
            want |= _OUT
        if want != conn.events:
            self._set_interest(conn, want)

    def _set_interest(self, conn: _Conn, want: int) -> None:
        if want == 0:
            # a client whose replies pile up unread: wait for it to drain
            want = _OUT
            if conn.events == want:
                return
        self._ep.modify(conn.sock.fileno(), want)
        conn.events = want

    def _drop(self, conn: _Conn, reason: str, *, abort: bool = False) -> None:
        """Close a connection; ``abort`` resets it, discarding whatever the kernel still
        holds for it (a client the server cut off gets nothing more and costs nothing)."""
        fd = conn.sock.fileno()
        if abort and fd >= 0:
            with contextlib.suppress(OSError):
                conn.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER,
                                     struct.pack("ii", 1, 0))
        if fd >= 0:
            with contextlib.suppress(OSError, ValueError):
                self._ep.unregister(fd)
        for k, v in list(self._conns.items()):
            if v is conn:
                del self._conns[k]
        self._by_session.pop(conn.session.id, None)
        conn.sock.close()
        self.core.close_session(conn.session)
        self.closed_connections += 1
        self._conn_log.log("leave", logging.INFO, "client %s left %s: %s", conn.session.peer,
                           conn.session.endpoint.name, reason)
