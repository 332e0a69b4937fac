"""Encoding whole messages and the sans-IO decoder.

``encode_message`` returns header and body as one ``bytes`` (one write per message).
``Decoder`` is fed arbitrary chunks and yields events::

    dec = Decoder()
    dec.feed(chunk)
    while (ev := dec.next_event()) is not NEED_DATA:
        ...  # Message or Undecodable; FrameError is raised for unframeable input
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final

from player_server.protocol.constants import HEADER_SIZE, MAX_MESSAGE_SIZE
from player_server.protocol.errors import DecodeError, EncodeError, FrameError
from player_server.protocol.header import HEADER_STRUCT, Header, Message
from player_server.protocol.registry import UnknownMessage, lookup
from player_server.protocol.xdr import decode_body

_pack_header = HEADER_STRUCT.pack
_unpack_header = HEADER_STRUCT.unpack_from
_make_header = Header._make


def encode_message(
    interf: int,
    index: int,
    msg_type: int,
    subtype: int,
    body: Any = None,
    *,
    timestamp: float = 0.0,
    host: int = 0,
    robot: int = 0,
    seq: int = 0,
) -> bytes:
    """Header + XDR body as one bytes object; ``size`` is the encoded body length."""
    if body is None:
        payload = b""
    else:
        try:
            encoder = type(body).xdr_encode
        except AttributeError:
            raise EncodeError(f"{type(body).__name__} is not a message body") from None
        payload = encoder(body)
    try:
        head = _pack_header(
            host, robot, interf, index, msg_type, subtype, timestamp, seq, len(payload)
        )
    except Exception as exc:
        raise EncodeError(f"bad header field: {exc}") from exc
    return head + payload


def encode(msg: Message) -> bytes:
    """Encode a ``Message`` (its header's ``size`` is recomputed)."""
    h = msg.header
    return encode_message(
        h.interf, h.index, h.type, h.subtype, msg.body,
        timestamp=h.timestamp, host=h.host, robot=h.robot, seq=h.seq,
    )


class _NeedData:
    _instance: _NeedData | None = None

    def __repr__(self) -> str:
        return "NEED_DATA"


NEED_DATA: Final = _NeedData()


@dataclass(frozen=True, slots=True)
class Undecodable:
    """A correctly framed message whose body could not be decoded (it was skipped)."""

    header: Header
    reason: str
    raw_body: bytes = b""


def decode_message(header: Header, body: bytes | memoryview) -> Message:
    """Decode one body for ``header``; raises DecodeError or UnknownMessage."""
    if header.size == 0:
        return Message(header, None)
    cls = lookup(header.interf, header.type, header.subtype)
    if cls is None:
        raise DecodeError(f"{header.interf}:{header.type}:{header.subtype} takes no body")
    return Message(header, decode_body(cls, body))


class Decoder:
    """Sans-IO framing and decoding of a Player byte stream (one per direction)."""

    def __init__(self, max_size: int = MAX_MESSAGE_SIZE) -> None:
        self._buf = bytearray()
        self._pos = 0
        self._max_size = max_size
        self._header: Header | None = None
        self.messages = 0
        self.undecodable = 0

    @property
    def buffered(self) -> int:
        return len(self._buf) - self._pos

    def feed(self, data: bytes | bytearray | memoryview) -> None:
        if self._pos and self._pos >= len(self._buf) // 2:
            del self._buf[: self._pos]
            self._pos = 0
        self._buf += data

    def next_event(self) -> Message | Undecodable | _NeedData:
        buf = self._buf
        pos = self._pos
        header = self._header
        if header is None:
            if len(buf) - pos < HEADER_SIZE:
                return NEED_DATA
            header = _make_header(_unpack_header(buf, pos))
            if header.size > self._max_size:
                raise FrameError(
                    f"message size {header.size} exceeds the limit {self._max_size}"
                )
            pos += HEADER_SIZE
            self._pos = pos
            self._header = header
        size = header.size
        end = pos + size
        if len(buf) < end:
            return NEED_DATA
        self._pos = end
        self._header = None
        if size == 0:
            self.messages += 1
            return Message(header, None)
        body = bytes(buf[pos:end])
        try:
            msg = decode_message(header, body)
        except (DecodeError, UnknownMessage) as exc:
            self.undecodable += 1
            reason = (
                f"no declaration for {exc.args[0]}" if isinstance(exc, UnknownMessage)
                else str(exc)
            )
            return Undecodable(header, reason, body)
        self.messages += 1
        return msg
