"""The client's receive buffer: Player frames split off a byte stream, bodies left undecoded.

A data round arrives as a handful of frames in one receive. Decoding every body into
message objects up front costs more than the robot does with most of them, so the client
walks the frames where they lie (`FrameBuffer.buf` between `start` and `end`) and lets each
proxy take its DATA body from there (see `Proxy._on_raw`). `decode_frame` turns one frame
into a `Message` for everything else (replies, SYNCH with a body, DATA read through a
request's backlog).
"""

from __future__ import annotations

import socket
import struct
from typing import Any

from player_server.protocol.codec import Undecodable
from player_server.protocol.constants import HEADER_SIZE
from player_server.protocol.errors import DecodeError
from player_server.protocol.header import HEADER_STRUCT, Header, Message
from player_server.protocol.registry import UnknownMessage, lookup

#: bytes kept free after the buffered data for the next receive before compacting
_MIN_ROOM = 64 * 1024


class FrameBuffer:
    """Received bytes not yet taken as frames: `buf[start:end]`; grows for large frames."""

    __slots__ = ("buf", "end", "start", "view")

    def __init__(self, capacity: int) -> None:
        self.buf = bytearray(capacity)
        self.view = memoryview(self.buf)
        self.start = 0
        self.end = 0

    @property
    def buffered(self) -> int:
        return self.end - self.start

    def receive(self, sock: socket.socket) -> int:
        """One ``recv_into`` after the buffered bytes (0 = the peer closed)."""
        if self.start == self.end:
            self.start = self.end = 0
        elif len(self.buf) - self.end < _MIN_ROOM:
            self._compact()
            if self.end == len(self.buf):  # full of one unfinished frame's start
                self.reserve(self.end - self.start + _MIN_ROOM)
        n = sock.recv_into(self.view[self.end:])
        self.end += n
        return n

    def reserve(self, frame_size: int) -> None:
        """Make room for a whole frame of `frame_size` bytes starting at `start`."""
        if self.start + frame_size <= len(self.buf):
            return
        self._compact()
        if frame_size > len(self.buf):
            self.view.release()
            self.buf.extend(bytes(frame_size - len(self.buf)))
            self.view = memoryview(self.buf)

    def _compact(self) -> None:
        start, end = self.start, self.end
        if start:
            self.buf[0:end - start] = self.buf[start:end]
            self.start, self.end = 0, end - start


def decode_frame(header: tuple[Any, ...], buf: Any, start: int, end: int
                 ) -> Message | Undecodable:
    """One framed body decoded in place into a `Message` (or why it cannot be)."""
    head = Header._make(header)
    if start == end:
        return Message(head, None)
    try:
        cls = lookup(head[2], head[4], head[5])
        if cls is None:
            raise DecodeError(f"{head[2]}:{head[4]}:{head[5]} takes no body")
        try:
            body, stop = cls.xdr_decode_raw(buf, start)
        except (struct.error, UnicodeDecodeError, TypeError, ValueError) as exc:
            raise DecodeError(f"{cls.__name__}: {exc}") from exc
        if stop != end:
            raise DecodeError(f"{cls.__name__}: {end - stop} unexpected trailing bytes"
                              if stop < end else f"{cls.__name__}: body runs past its size")
    except UnknownMessage as exc:
        return Undecodable(head, f"no declaration for {exc.args[0]}", bytes(buf[start:end]))
    except DecodeError as exc:
        return Undecodable(head, str(exc), bytes(buf[start:end]))
    return Message(head, body)


#: (interface, type, subtype) -> the body class's raw decoder, for replies seen before
_REPLY_DECODERS: dict[tuple[int, int, int], Any] = {}


def decode_reply(header: tuple[Any, ...], buf: Any, start: int, end: int) -> Any:
    """The body of a reply frame decoded in place (``None`` if empty), or `Undecodable`.

    The same result as `decode_frame` without building a `Message`: a request's reply is
    all its caller wants, once per request.
    """
    if start == end:
        return None
    key = (header[2], header[4], header[5])
    decode = _REPLY_DECODERS.get(key)
    if decode is not None:
        try:
            body, stop = decode(buf, start)
        except (struct.error, UnicodeDecodeError, TypeError, ValueError):
            pass
        else:
            if stop == end:
                return body
    frame = decode_frame(header, buf, start, end)  # what is wrong with it, if anything
    if isinstance(frame, Undecodable):
        return frame
    _REPLY_DECODERS[key] = lookup(*key).xdr_decode_raw
    return frame.body


HEADER = HEADER_STRUCT
HEADER_LEN = HEADER_SIZE
