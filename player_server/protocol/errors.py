"""Errors raised by the codec."""

from __future__ import annotations


class ProtocolError(Exception):
    """Base class of every codec error."""


class EncodeError(ProtocolError):
    """A value does not fit its wire type (out of range, too long, wrong type)."""


class DecodeError(ProtocolError):
    """A body does not decode as its declared struct."""


class FrameError(ProtocolError):
    """The byte stream cannot be framed any more (e.g. a size beyond the limit).

    The connection that produced it cannot be resynchronised and must be closed.
    """
