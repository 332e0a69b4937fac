"""The 40-byte message header and a whole message (header + decoded body)."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any, NamedTuple

from player_server.protocol.constants import HEADER_SIZE

HEADER_STRUCT = struct.Struct(">IIIIIIdII")
assert HEADER_STRUCT.size == HEADER_SIZE


class Header(NamedTuple):
    """``player_msghdr_t``: address, type, subtype, timestamp [s], seq, body size [B].

    An immutable record (a named tuple: millions are made, and tuples are cheapest).
    """

    host: int
    robot: int
    interf: int
    index: int  # type: ignore[assignment]  # shadows tuple.index, as Player names it
    type: int
    subtype: int
    timestamp: float = 0.0
    seq: int = 0
    size: int = 0

    def pack(self) -> bytes:
        return HEADER_STRUCT.pack(
            self.host, self.robot, self.interf, self.index, self.type, self.subtype,
            self.timestamp, self.seq, self.size,
        )

    @classmethod
    def unpack(cls, buf: bytes | memoryview, offset: int = 0) -> Header:
        return cls._make(HEADER_STRUCT.unpack_from(buf, offset))


@dataclass(frozen=True, slots=True)
class Message:
    """A framed message: its header and its body (a body dataclass, or ``None`` if empty)."""

    header: Header
    body: Any = None

    @property
    def interf(self) -> int:
        return self.header.interf

    @property
    def index(self) -> int:
        return self.header.index

    @property
    def type(self) -> int:
        return self.header.type

    @property
    def subtype(self) -> int:
        return self.header.subtype

    @property
    def timestamp(self) -> float:
        return self.header.timestamp
