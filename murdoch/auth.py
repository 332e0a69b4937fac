"""Optional datagram authentication with a shared team key, and replay rejection.

A signed datagram is the plain datagram (see `murdoch.wire`) with one more member at the end,
written exactly as ``,"mac":"<64 lowercase hex digits>"}``::

    {"h":[3,"bid","r2","9c41d2e7",17,"task.x",-1,""],"b":{...},"mac":"3f0c...e1"}

The tag is HMAC-SHA256(key, every byte before ``,"mac":``), so it covers the exact bytes of
the header and the body, everything a receiver acts on, with no re-serialisation on either
side; the datagram stays one JSON object. Each sender numbers its datagrams; a `ReplayWindow`
per receiver remembers, per sender instance (sender id + the nonce a transport draws when it
opens), the highest sequence seen and which of the previous `window` numbers arrived, and
rejects repeats and numbers older than the window; a restarted process is a new instance
from 0.
"""

from __future__ import annotations

import hashlib
import hmac
from collections import OrderedDict

from murdoch.wire import MAC_KEY, WireError, signed_length


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
        return hmac.digest(self._secret, data, hashlib.sha256).hex().encode("ascii")

    def sign(self, plain: bytes) -> bytes:
        """Signed datagram for `plain` (an unsigned datagram: one JSON object)."""
        if plain[:1] != b"{" or plain[-1:] != b"}" or is_signed(plain):
            raise ValueError("can only sign an unsigned datagram (one JSON object)")
        covered = plain[:-1]
        return covered + MAC_KEY + self._tag(covered) + b'"}'

    def check(self, datagram: bytes) -> None:
        """WireError('auth_failed') unless `datagram` ends with a matching tag member."""
        at = signed_length(datagram)
        if at < 0:
            raise WireError("auth_failed", "datagram carries no tag")
        tag = datagram[at + len(MAC_KEY) : -2]
        if not hmac.compare_digest(tag, self._tag(datagram[:at])):
            raise WireError("auth_failed", "tag does not match")

    def verify(self, datagram: bytes) -> bytes:
        """The unsigned datagram inside `datagram`, or WireError('auth_failed')."""
        self.check(datagram)
        return strip_tag(datagram)


def is_signed(datagram: bytes) -> bool:
    """Whether `datagram` ends with a tag member (whether it matches is `TeamKey.check`'s)."""
    return signed_length(datagram) >= 0


def strip_tag(datagram: bytes) -> bytes:
    """The unsigned datagram of a signed one without checking the tag (for key-less tools)."""
    at = signed_length(datagram)
    return datagram if at < 0 else datagram[:at] + b"}"


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
