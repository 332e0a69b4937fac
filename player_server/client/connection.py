"""A blocking Player client with libplayerc's shape.

::

    with PlayerClient("127.0.0.1", 6665) as client:      # banner, then PULL mode
        pos = client.subscribe(Position2dProxy, 0)
        laser = client.subscribe(LaserProxy, 0)
        while ...:
            client.read()                     # one full data round (REQ DATA ... SYNCH)
            pos.set_velocity(0.2, 0.0)         # commands return at once
            print(client.data_time_s, pos.x, min(laser.ranges))

``read()`` in PULL mode asks for a round, then dispatches each DATA to the proxy with the
same interface and index until the SYNCH; requests wait for their ACK/NACK (DATA that
arrives meanwhile is kept for the next ``read``). Requests and reads are serialised with
a lock; commands may be sent from any thread.

Lockstep servers count a PULL client that subscribes to position2d as a participant that
the simulation waits for. Pass ``lockstep=False`` for observers that must not hold the
simulation (``True`` forces participation). In lockstep, send a tick's commands before the
next ``read()``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, TypeVar

from player_server.client.errors import (
    PlayerConnectionClosed,
    PlayerConnectionError,
    PlayerNack,
    PlayerTimeout,
)
from player_server.client.framing import FrameBuffer, decode_frame, decode_reply
from player_server.client.proxy import Proxy
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol.codec import Undecodable, encode_message
from player_server.protocol.common import DevAddr
from player_server.protocol.constants import MsgType
from player_server.protocol.errors import DecodeError
from player_server.protocol.header import HEADER_STRUCT, Header, Message

log = logging.getLogger(__name__)

P = TypeVar("P", bound=Proxy)

_DATA, _CMD, _REQ = int(MsgType.DATA), int(MsgType.CMD), int(MsgType.REQ)
_ACK, _NACK, _SYNCH = int(MsgType.RESP_ACK), int(MsgType.RESP_NACK), int(MsgType.SYNCH)
_PLAYER = int(c.Interface.PLAYER)
#: longest single wait inside a receive; timeouts are checked between slices
_RECV_SLICE_S = 0.1
_RECV_SIZE = 256 * 1024
#: wake a reader waiting for a round only for more than a lone reply header
_ROUND_LOWAT = c.HEADER_SIZE + 1
_HEADER = HEADER_STRUCT
_pack_header = HEADER_STRUCT.pack
_unpack_header = HEADER_STRUCT.unpack_from


def _request_wire(interf: int, index: int, subtype: int, body: Any, now: float) -> bytes:
    """A REQ as `encode_message` makes it; one without a body (the common case) is its
    header alone, packed at once."""
    if body is None:
        try:
            return _pack_header(0, 0, interf, index, _REQ, subtype, now, 0, 0)
        except struct.error:
            pass  # encode_message says what is wrong
    return encode_message(interf, index, _REQ, subtype, body, timestamp=now)
_HEADER_SIZE = c.HEADER_SIZE
_MAX_SIZE = c.MAX_MESSAGE_SIZE
_REQ_DATA = c.PLAYER_REQ_DATA
_SYNCH_OVERFLOW = c.PLAYER_SYNCH_OVERFLOW


class PlayerClient:
    """One TCP connection to one port (robot) of a Player server."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = c.DEFAULT_PORT,
        *,
        timeout_s: float = 5.0,
        read_timeout_s: float = 60.0,
        lockstep: bool | None = None,
        mode: int = c.PLAYER_DATAMODE_PULL,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.host = host
        self.port = port
        self.timeout_s = timeout_s
        self.read_timeout_s = read_timeout_s
        self.lockstep = lockstep
        self._wanted_mode = mode
        self._clock = clock
        self._sock: socket.socket | None = None
        self._frames = FrameBuffer(_RECV_SIZE)
        self._lowat = 1
        self._backlog: deque[Message] = deque()
        self._io_lock = threading.RLock()
        self._send_lock = threading.Lock()
        self._pending: list[bytes] = []
        self._round_outstanding = False
        self.proxies: dict[tuple[int, int], Proxy] = {}
        self.banner = ""
        self.mode = c.PLAYER_DATAMODE_PUSH
        self.data_time_s: float | None = None
        self.overflow_count = 0
        self.undecodable = 0
        self.rounds = 0

    # -- connection -------------------------------------------------------------------------
    def _opened(self, sock: socket.socket) -> None:
        """The socket is connected and held; the handshake comes next (a subclass's hook)."""

    def connect(self, timeout_s: float | None = None) -> PlayerClient:
        """Open the connection, read the banner and switch to the wanted data mode."""
        timeout = self.timeout_s if timeout_s is None else timeout_s
        try:
            sock = socket.create_connection((self.host, self.port), timeout=timeout)
        except OSError as exc:
            raise PlayerConnectionError(
                f"cannot connect to {self.host}:{self.port}: {exc}") from exc
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock = sock
        self._opened(sock)
        self._lowat = 1
        try:
            banner = b""
            deadline = self._clock() + timeout
            while len(banner) < c.BANNER_SIZE:
                sock.settimeout(max(deadline - self._clock(), 1e-3))
                chunk = sock.recv(c.BANNER_SIZE - len(banner))
                if not chunk:
                    raise PlayerConnectionError("the server closed the connection at once")
                banner += chunk
            self.banner = banner.split(b"\0", 1)[0].decode("ascii", "replace")
            try:
                sock.settimeout(None)
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO,
                                struct.pack("ll", 0, int(_RECV_SLICE_S * 1e6)))
            except (OSError, struct.error):
                sock.settimeout(_RECV_SLICE_S)  # no SO_RCVTIMEO: Python's own timeout
            if self._wanted_mode != c.PLAYER_DATAMODE_PUSH:
                self.set_datamode(self._wanted_mode)
            if self.lockstep is not None:
                try:
                    self.request(_PLAYER, 0, c.PLAYER_SET_INTPROP_REQ,
                                 pm.IntPropReq("lockstep", int(self.lockstep)))
                except PlayerNack:
                    log.info("the server has no lockstep property (not our server?)")
        except (OSError, PlayerNack, PlayerTimeout) as exc:
            self.close()
            if isinstance(exc, PlayerConnectionError):
                raise
            raise PlayerConnectionError(f"handshake with {self.host}:{self.port} failed: "
                                        f"{exc}") from exc
        return self

    def close(self) -> None:
        if self._pending and self._sock is not None:
            with contextlib.suppress(PlayerConnectionError):
                self.flush()
        sock, self._sock = self._sock, None
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.close()

    @property
    def connected(self) -> bool:
        return self._sock is not None

    def __enter__(self) -> PlayerClient:
        if self._sock is None:
            self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- low level --------------------------------------------------------------------------
    def _send(self, wire: bytes) -> None:
        sock = self._sock
        if sock is None:
            raise PlayerConnectionError("not connected")
        with self._send_lock:
            if self._pending:
                self._pending.append(wire)
                wire = b"".join(self._pending)
                self._pending.clear()
            try:
                sock.sendall(wire)
            except (ConnectionResetError, BrokenPipeError) as exc:
                self.close()
                raise PlayerConnectionClosed("the server closed the connection") from exc
            except OSError as exc:
                self.close()
                raise PlayerConnectionError(f"send failed: {exc}") from exc

    def _set_lowat(self, sock: socket.socket, lowat: int) -> None:
        if lowat != self._lowat:
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVLOWAT, lowat)
            except (OSError, AttributeError):
                return  # not supported: every arrival wakes the reader, which is only slower
            self._lowat = lowat

    def _frame_size(self, header: tuple[Any, ...]) -> int:
        size: int = header[8]
        if size > _MAX_SIZE:
            self.close()
            raise PlayerConnectionError(
                f"unframeable stream from server: message size {size} exceeds the limit "
                f"{_MAX_SIZE}")
        return size

    def _skip(self, reason: str) -> None:
        self.undecodable += 1
        log.warning("skipping a message that does not decode: %s", reason)

    def _receive(self, deadline: float | None, round_wait: bool = False) -> None:
        """Receive once into the frame buffer (blocking until ``deadline``).

        ``round_wait``: a PULL round was asked for and its ACK has not come yet. In
        lockstep the ACK arrives alone and the round only after the step; waking for the
        lone 40-byte ACK would cost a second wake-up per tick, so the receive then waits
        for more than one header's worth of bytes (SO_RCVLOWAT). A receive slice that
        ends returns what has arrived, so a lone reply still gets through in one slice.
        """
        frames = self._frames
        while True:
            sock = self._sock
            if sock is None:
                raise PlayerConnectionError("not connected")
            if deadline is not None and deadline - self._clock() <= 0:
                raise PlayerTimeout("timed out waiting for the server")
            lowat = _ROUND_LOWAT if round_wait and frames.end == frames.start else 1
            if lowat != self._lowat:
                self._set_lowat(sock, lowat)
            try:
                # a blocking recv bounded by SO_RCVTIMEO slices: one system call per
                # receive (a Python socket timeout would add a poll() to each), into a
                # buffer allocated once (a fresh 256 KiB bytes per recv costs an
                # mmap/munmap pair and page faults)
                n = frames.receive(sock)
            except (BlockingIOError, TimeoutError, InterruptedError):
                continue  # a slice ended: check the deadline and wait again
            except ConnectionResetError as exc:
                self.close()
                raise PlayerConnectionClosed("the server closed the connection") from exc
            except OSError as exc:
                self.close()
                raise PlayerConnectionError(f"receive failed: {exc}") from exc
            if not n:
                self.close()
                raise PlayerConnectionClosed("the server closed the connection")
            return

    def _deadline(self, timeout_s: float | None, default: float) -> float | None:
        t = default if timeout_s is None else timeout_s
        return None if t <= 0 else self._clock() + t

    # -- requests and commands ----------------------------------------------------------------
    def request(
        self,
        interf: int,
        index: int,
        subtype: int,
        body: Any = None,
        timeout_s: float | None = None,
    ) -> Any:
        """Send a REQ and return the ACK's body (``None`` if empty).

        Raises ``PlayerNack`` on a NACK and ``PlayerTimeout`` when no reply comes in time.
        """
        now = self._clock()
        wire = _request_wire(interf, index, subtype, body, now)
        limit = self.timeout_s if timeout_s is None else timeout_s
        deadline = None if limit <= 0 else now + limit
        frames = self._frames
        with self._io_lock:
            self._send(wire)
            while True:
                # the reply where it lies in the receive buffer; what precedes it is
                # decoded and kept in the backlog for the next read()
                buf, pos = frames.buf, frames.start
                if frames.end - pos < _HEADER_SIZE:
                    self._receive(deadline)
                    continue
                head = _unpack_header(buf, pos)
                start = pos + _HEADER_SIZE
                size = head[8]
                stop = start + (size if size <= _MAX_SIZE else self._frame_size(head))
                if stop > frames.end:
                    frames.reserve(stop - pos)
                    self._receive(deadline)
                    continue
                frames.start = stop
                t = head[4]
                if t not in (_ACK, _NACK):
                    msg = decode_frame(head, buf, start, stop)
                    if isinstance(msg, Undecodable):
                        self._skip(msg.reason)
                    else:
                        self._backlog.append(msg)
                    continue
                reply = decode_reply(head, buf, start, stop)
                if isinstance(reply, Undecodable):
                    self._skip(reply.reason)
                    reply = None  # a reply still answers its request
                if head[2] != interf or head[3] != index or head[5] != subtype:
                    log.warning("discarding an unclaimed reply %s", Header._make(head))
                elif t == _NACK:
                    raise PlayerNack(interf, index, subtype, reply)
                else:
                    return reply

    def clock(self) -> float:
        """The client's clock (header timestamps of what it sends)."""
        return self._clock()

    def send_encoded(self, wire: bytes, *, defer: bool = False) -> None:
        """Send one already encoded message (header and body), e.g. a prepacked CMD.

        ``defer=True`` holds it until the next message goes out (in a PULL client's
        ``read()``: the REQ DATA, so a tick's command and the request for the next round
        leave in one system call and one segment, in that order), or until ``flush()`` or
        ``close()``. ``read()`` flushes before waiting in any case.
        """
        if defer:
            with self._send_lock:
                self._pending.append(wire)
            return
        self._send(wire)

    def flush(self) -> None:
        """Send any deferred messages now."""
        if self._pending:
            self._send(b"")

    def command(self, interf: int, index: int, subtype: int, body: Any = None) -> None:
        """Send a CMD (never answered)."""
        self._send(encode_message(interf, index, _CMD, subtype, body, timestamp=self._clock()))

    def set_datamode(self, mode: int) -> None:
        self.request(_PLAYER, 0, c.PLAYER_REQ_DATAMODE, pm.DeviceDatamodeReq(mode))
        self.mode = mode
        self._round_outstanding = False

    def set_replace_rule(self, replace: int, interf: int = -1, index: int = -1,
                         msg_type: int = -1, subtype: int = -1) -> None:
        self.request(_PLAYER, 0, c.PLAYER_REQ_ADD_REPLACE_RULE,
                     pm.AddReplaceRuleReq(interf, index, msg_type, subtype, replace))

    def devlist(self) -> tuple[DevAddr, ...]:
        reply = self.request(_PLAYER, 0, c.PLAYER_REQ_DEVLIST)
        return tuple(reply.devices) if reply is not None else ()

    def driver_name(self, interf: int, index: int) -> str:
        reply = self.request(_PLAYER, 0, c.PLAYER_REQ_DRIVERINFO,
                             pm.DeviceDriverInfo(DevAddr(0, 0, interf, index), ""))
        return str(reply.driver_name)

    def is_lockstep_participant(self) -> bool:
        reply = self.request(_PLAYER, 0, c.PLAYER_GET_INTPROP_REQ, pm.IntPropReq("lockstep", 0))
        return bool(reply.value)

    # -- proxies ------------------------------------------------------------------------------
    def subscribe(self, proxy_cls: type[P], index: int = 0, timeout_s: float | None = None) -> P:
        """Open a device and return its proxy (NACK -> ``PlayerNack``)."""
        reply = self.request(
            _PLAYER, 0, c.PLAYER_REQ_DEV,
            pm.DeviceReq(DevAddr(0, 0, proxy_cls.interf, index), c.PLAYER_OPEN_MODE, ""),
            timeout_s,
        )
        proxy = proxy_cls(self, index)
        proxy.driver_name = reply.driver_name if reply is not None else ""
        self.proxies[(proxy_cls.interf, index)] = proxy
        return proxy

    def unsubscribe(self, proxy: Proxy, timeout_s: float | None = None) -> None:
        self.proxies.pop((proxy.interf, proxy.index), None)
        self.request(
            _PLAYER, 0, c.PLAYER_REQ_DEV,
            pm.DeviceReq(DevAddr(0, 0, proxy.interf, proxy.index), c.PLAYER_CLOSE_MODE, ""),
            timeout_s,
        )

    def _dispatch(self, msg: Message) -> Proxy | None:
        h = msg.header
        proxy = self.proxies.get((h.interf, h.index))
        if proxy is None:
            log.debug("data for %d:%d without a proxy", h.interf, h.index)
            return None
        proxy._on_data(h.subtype, msg.body, h.timestamp)
        self.data_time_s = h.timestamp
        return proxy

    def _data_proxy(self, rnd: _Round, head: tuple[Any, ...]) -> Proxy | None:
        """The proxy a DATA message with header fields `head` is for (None, logged, when no
        proxy is open for its device); the round has had data either way."""
        rnd.got_data = True
        proxy = self.proxies.get((head[2], head[3]))
        if proxy is None:
            log.debug("data for %d:%d without a proxy", head[2], head[3])
        return proxy

    def read(self, timeout_s: float | None = None) -> list[Proxy]:
        """Wait for one full data round (PULL) or one DATA (PUSH); return updated proxies.

        In PULL mode the REQ DATA's ACK (within ``timeout_s``, default the request
        timeout) and the round (within ``read_timeout_s``) are read in one pass. DATA
        bodies are handed to their proxies where they lie in the receive buffer; a body
        that does not decode is skipped (logged and counted in ``undecodable``).
        """
        with self._io_lock:
            deadline = self._deadline(timeout_s, self.read_timeout_s)
            pull = self.mode == c.PLAYER_DATAMODE_PULL
            backlog = self._backlog
            ack_wait = False
            ack_deadline = None
            if (pull and not self._round_outstanding
                    and not (backlog and any(m.header.type == _SYNCH for m in backlog))):
                self._send(_HEADER.pack(0, 0, _PLAYER, 0, _REQ, _REQ_DATA, self._clock(), 0, 0))
                self._round_outstanding = True
                ack_wait = True
                ack_deadline = self._deadline(timeout_s, self.timeout_s)
            elif self._pending:
                self.flush()
            rnd = _Round(pull, ack_wait)
            updated = rnd.updated
            frames = self._frames
            unpack_header = _HEADER.unpack_from
            while True:
                # messages decoded while a request waited for its reply come first
                while backlog:
                    msg = backlog.popleft()
                    head = msg.header
                    if head[4] == _DATA:
                        proxy = self._data_proxy(rnd, head)
                        if proxy is not None:
                            proxy._on_data(head[5], msg.body, head[6])
                            self.data_time_s = head[6]
                            if proxy not in updated:
                                updated.append(proxy)
                        if not pull:
                            return updated
                    else:
                        self._take(rnd, head, msg.body)
                        if rnd.done:
                            return updated
                # then the frames where they lie in the receive buffer
                buf, pos, end = frames.buf, frames.start, frames.end
                while end - pos >= _HEADER_SIZE:
                    h = unpack_header(buf, pos)
                    size = h[8]
                    if size > _MAX_SIZE:
                        self._frame_size(h)
                    start = pos + _HEADER_SIZE
                    stop = start + size
                    if stop > end:
                        frames.reserve(stop - pos)
                        break
                    pos = frames.start = stop
                    if h[4] == _DATA:
                        proxy = self._data_proxy(rnd, h)
                        if proxy is not None:
                            try:
                                proxy._on_raw(h[5], buf, start, stop, h[6])
                            except DecodeError as exc:
                                self._skip(str(exc))
                            else:
                                self.data_time_s = h[6]
                                if proxy not in updated:
                                    updated.append(proxy)
                        if not pull:
                            return updated
                        continue
                    if size:
                        frame = decode_frame(h, buf, start, stop)
                        if isinstance(frame, Undecodable):
                            self._skip(frame.reason)
                            if h[4] not in (_ACK, _NACK):
                                continue
                            self._take(rnd, h, None)  # a reply still answers its request
                        else:
                            self._take(rnd, h, frame.body)
                    else:
                        self._take(rnd, h, None)
                    if rnd.done:
                        return updated
                if rnd.ack_wait:
                    self._receive(ack_deadline if deadline is None or (
                        ack_deadline is not None and ack_deadline < deadline) else deadline,
                        True)
                else:
                    self._receive(deadline)

    def _take(self, rnd: _Round, h: tuple[Any, ...], body: Any) -> None:
        """Account for one message of a round other than DATA."""
        t = h[4]
        if t == _SYNCH:
            if h[5] == _SYNCH_OVERFLOW and body is not None:
                self.overflow_count += body.dropped
            self._round_outstanding = False
            if rnd.pull:
                self.rounds += 1
                if not rnd.got_data:
                    log.warning("a data round without data")
                rnd.synched = True
                if not rnd.ack_wait:
                    rnd.done = True
        elif t in (_ACK, _NACK):
            if rnd.ack_wait and h[2] == _PLAYER and h[3] == 0 and h[5] == _REQ_DATA:
                rnd.ack_wait = False
                if t == _NACK:
                    self._round_outstanding = False
                    raise PlayerNack(_PLAYER, 0, _REQ_DATA, body)
                if rnd.synched:
                    rnd.done = True
            else:
                log.warning("discarding an unclaimed reply %s", Header._make(h))


class _Round:
    """What one ``read()`` has seen so far."""

    __slots__ = ("ack_wait", "done", "got_data", "pull", "synched", "updated")

    def __init__(self, pull: bool, ack_wait: bool) -> None:
        self.pull = pull
        self.ack_wait = ack_wait
        self.done = False
        self.got_data = False
        self.synched = False
        self.updated: list[Proxy] = []
