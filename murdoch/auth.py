"""Optional datagram authentication with a shared team key, and replay rejection.

An authenticated datagram is the plain JSON datagram with ``"h": "<64 hex digits>"`` put first::

    {"h":"<HMAC-SHA256(key, plain)>",<the plain datagram without its opening brace>

so it stays one JSON object, and the tag covers the exact bytes of the plain datagram (no
re-serialisation on the receiving side). Each sender numbers its datagrams; a `ReplayWindow`
per receiver remembers, per sender instance (sender id + the nonce a transport draws when it opens),
the highest sequence seen and which of the previous `window` numbers arrived, and rejects
repeats and numbers older than the window; a restarted process is a new instance from 0.
"""

from __future__ import annotations

import hashlib
import hmac
from collections import OrderedDict

from murdoch.wire import WireError

_PREFIX = b'{"h":"'
_TAG_HEX = 64
_AFTER = b'",'


class TeamKey:
    """A shared secret used to sign and verify datagrams."""

    def __init__(self, secret: bytes | str) -> None:
        raw = secret.encode("utf-8") if isinstance(secret, str) else bytes(secret)
        if len(raw) < 8:
            raise ValueError("a team key needs at least 8 bytes")
        self._secret = raw

    def __repr__(self) -> str:
        return "TeamKey(<hidden>)"

    def _tag(self, data: bytes) -> bytes:
        return hmac.new(self._secret, data, hashlib.sha256).hexdigest().encode("ascii")

    def sign(self, plain: bytes) -> bytes:
        """Authenticated datagram for `plain` (a JSON object's bytes)."""
        if not plain.startswith(b"{") or plain == b"{}":
            raise ValueError("can only sign a non-empty JSON object")
        return _PREFIX + self._tag(plain) + _AFTER + plain[1:]

    def verify(self, datagram: bytes) -> bytes:
        """The plain datagram inside `datagram`, or WireError('auth_failed')."""
        head = len(_PREFIX)
        if not is_signed(datagram):
            raise WireError("auth_failed", "datagram carries no tag")
        tag = datagram[head : head + _TAG_HEX]
        plain = b"{" + datagram[head + _TAG_HEX + len(_AFTER) :]
        if not hmac.compare_digest(tag, self._tag(plain)):
            raise WireError("auth_failed", "tag does not match")
        return plain


def is_signed(datagram: bytes) -> bool:
    head = len(_PREFIX)
    return (
        datagram.startswith(_PREFIX)
        and datagram[head + _TAG_HEX : head + _TAG_HEX + len(_AFTER)] == _AFTER
    )


def strip_tag(datagram: bytes) -> bytes:
    """The plain datagram of a signed one without checking the tag (for key-less listeners)."""
    if not is_signed(datagram):
        return datagram
    return b"{" + datagram[len(_PREFIX) + _TAG_HEX + len(_AFTER) :]


class ReplayWindow:
    """Per-sender sliding window of accepted sequence numbers."""

    def __init__(self, window: int = 1024, max_senders: int = 4096) -> None:
        if window < 1 or max_senders < 1:
            raise ValueError("window and max_senders must be positive")
        self.window = window
        self.max_senders = max_senders
        self._state: OrderedDict[str, tuple[int, int]] = OrderedDict()  # sender -> (top, bits)

    def accept(self, sender: str, seq: int) -> bool:
        """Record `seq` from `sender`; False if it was seen before or is too old."""
        state = self._state.get(sender)
        if state is None:
            self._state[sender] = (seq, 1)
            if len(self._state) > self.max_senders:
                self._state.popitem(last=False)
            return True
        self._state.move_to_end(sender)
        top, bits = state
        mask = (1 << self.window) - 1
        if seq > top:
            shift = seq - top
            bits = ((bits << shift) | 1) & mask if shift < self.window else 1
            self._state[sender] = (seq, bits)
            return True
        offset = top - seq
        if offset >= self.window or (bits >> offset) & 1:
            return False
        self._state[sender] = (top, bits | (1 << offset))
        return True
