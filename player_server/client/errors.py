"""Errors raised by the Player client."""

from __future__ import annotations

from typing import Any

from player_server.protocol.constants import interface_name


class PlayerError(Exception):
    """Base class of client errors."""


class PlayerConnectionError(PlayerError):
    """Connecting failed, or the connection broke."""


class PlayerConnectionClosed(PlayerConnectionError):
    """The server ended the connection: an orderly close, or a reset (a server that stops
    closes sockets with unread data in them, which the peer sees as a reset)."""


class PlayerTimeout(PlayerError):
    """No answer from the server in time."""


class PlayerNack(PlayerError):
    """The server answered a request with a NACK."""

    def __init__(self, interf: int, index: int, subtype: int, body: Any = None) -> None:
        super().__init__(f"request {subtype} to {interface_name(interf)}:{index} was refused")
        self.interf = interf
        self.index = index
        self.subtype = subtype
        self.body = body
