"""Encoding whole messages and the sans-IO decoder.

``encode_message`` returns header and body as one ``bytes`` (one write per message).
``Decoder`` is fed arbitrary chunks and yields events::

    dec = Decoder()
    dec.feed(chunk)
    while (ev := dec.next_event()) is not NEED_DATA:
        ...  # Message or Undecodable; FrameError is raised for unframeable input
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any, Final

from player_server.frozen import frozen_constructor
from player_server.protocol.constants import HEADER_SIZE, MAX_MESSAGE_SIZE
from player_server.protocol.errors import DecodeError, EncodeError, FrameError
from player_server.protocol.header import HEADER_STRUCT, Header, Message
from player_server.protocol.registry import UnknownMessage, lookup
from player_server.protocol.xdr import decode_body

_pack_header = HEADER_STRUCT.pack
_unpack_header = HEADER_STRUCT.unpack_from
_make_header = Header._make
_make_message = frozen_constructor(Message)


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
    payload = b"" if body is None else encode_payload(body)
    try:
        head = _pack_header(
            host, robot, interf, index, msg_type, subtype, timestamp, seq, len(payload)
        )
    except Exception as exc:
        raise EncodeError(f"bad header field: {exc}") from exc
    return head + payload


def encode_payload(body: Any) -> bytes:
    """A body's XDR bytes (what `encode_message` puts after the header)."""
    try:
        encoder = type(body).xdr_encode
    except AttributeError:
        raise EncodeError(f"{type(body).__name__} is not a message body") from None
    return encoder(body)


def encode_with_payload(interf: int, index: int, msg_type: int, subtype: int, payload: bytes,
                        *, timestamp: float = 0.0, robot: int = 0) -> bytes:
    """Header + an already encoded body (`encode_payload`), as `encode_message` makes them."""
    try:
        head = _pack_header(0, robot, interf, index, msg_type, subtype, timestamp, 0,
                            len(payload))
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
        self._decoders: dict[tuple[int, int, int], Any] = {}
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
            return _make_message(header, None)
        return self._decode(header, buf, pos, end)

    def events(self) -> list[Message | Undecodable]:
        """Every complete message now buffered, in order (``[]`` = need data).

        The same events as calling ``next_event`` until ``NEED_DATA``, in one pass. A
        frame over the size limit raises ``FrameError`` once the messages before it have
        been returned.
        """
        out: list[Message | Undecodable] = []
        if self._header is not None:
            ev = self.next_event()
            if ev is NEED_DATA:
                return out
            out.append(ev)  # type: ignore[arg-type]
        buf = self._buf
        pos = self._pos
        have = len(buf)
        max_size = self._max_size
        append = out.append
        empty = 0
        while have - pos >= HEADER_SIZE:
            header = _make_header(_unpack_header(buf, pos))
            size = header[8]
            if size > max_size:
                self._pos = pos
                if out:
                    break
                raise FrameError(f"message size {size} exceeds the limit {max_size}")
            start = pos + HEADER_SIZE
            end = start + size
            if end > have:
                self._pos = start
                self._header = header
                break
            pos = end
            if size == 0:
                empty += 1
                append(_make_message(header, None))
            else:
                self._pos = pos
                append(self._decode(header, buf, start, end))
        else:
            self._pos = pos
        self.messages += empty
        return out

    def _decode(self, header: Header, buf: bytearray, pos: int, end: int
                ) -> Message | Undecodable:
        # the body is decoded where it lies in the buffer (no copy) by the class's
        # unwrapped decoder; it must end exactly at the frame's end
        key = (header[2], header[4], header[5])
        entry = self._decoders.get(key)
        try:
            if entry is None:
                entry = self._decoders[key] = _body_decoder(*key)
            decode, name = entry
            try:
                body, stop = decode(buf, pos)
            except (struct.error, UnicodeDecodeError, TypeError, ValueError) as exc:
                raise DecodeError(f"{name}: {exc}") from exc
            if stop != end:
                raise DecodeError(f"{name}: {end - stop} unexpected trailing bytes"
                                  if stop < end else f"{name}: body runs past its size")
        except (DecodeError, UnknownMessage) as exc:
            self.undecodable += 1
            reason = (
                f"no declaration for {exc.args[0]}" if isinstance(exc, UnknownMessage)
                else str(exc)
            )
            return Undecodable(header, reason, bytes(buf[pos:end]))
        self.messages += 1
        return _make_message(header, body)


def _body_decoder(interf: int, msg_type: int, subtype: int) -> tuple[Any, str]:
    """``(decode(buf, offset) -> (body, end), class name)`` for one message kind.

    Raises UnknownMessage when the kind is not declared.
    """
    cls = lookup(interf, msg_type, subtype)
    if cls is None:
        def no_body(buf: Any, offset: int) -> tuple[Any, int]:
            raise DecodeError(f"{interf}:{msg_type}:{subtype} takes no body")
        return no_body, "none"
    return cls.xdr_decode_raw, cls.__name__
