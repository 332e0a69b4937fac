"""Player 3.x wire codec: pure, socket-free.

Bodies are frozen dataclasses declared once each (``*_msgs.py``); ``registry`` maps
(interface, type, subtype) to them; ``codec`` frames whole messages and holds the sans-IO
``Decoder``.
"""

from player_server.protocol.codec import (
    NEED_DATA,
    Decoder,
    Undecodable,
    decode_message,
    encode,
    encode_message,
)
from player_server.protocol.constants import Interface, MsgType, banner
from player_server.protocol.errors import DecodeError, EncodeError, FrameError, ProtocolError
from player_server.protocol.header import Header, Message
from player_server.protocol.registry import UnknownMessage, lookup

__all__ = [
    "NEED_DATA",
    "DecodeError",
    "Decoder",
    "EncodeError",
    "FrameError",
    "Header",
    "Interface",
    "Message",
    "MsgType",
    "ProtocolError",
    "Undecodable",
    "UnknownMessage",
    "banner",
    "decode_message",
    "encode",
    "encode_message",
    "lookup",
]
