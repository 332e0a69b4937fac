"""Encoded DATA bodies kept while a driver hands back the same body object.

A driver returns the same body object while its reading is unchanged (a robot standing
still, a team clock table no count changed in): its XDR bytes are made once and re-used,
and only the header (timestamp, robot) is new each round.
"""

from __future__ import annotations

from typing import Any

from player_server.protocol.codec import encode_payload, encode_with_payload
from player_server.protocol.constants import MsgType

_DATA = int(MsgType.DATA)


class PayloadCache:
    """The last body of each (device key, DATA subtype) and its encoded bytes."""

    def __init__(self) -> None:
        self._last: dict[tuple[object, int], tuple[Any, bytes]] = {}

    def wire(self, key: object, interf: int, index: int, subtype: int, body: Any,
             timestamp: float, robot: int) -> bytes:
        """The whole DATA message (header and body) of ``body`` from device ``key``."""
        pk = (key, subtype)
        known = self._last.get(pk)
        if known is not None and known[0] is body:
            payload = known[1]
        else:
            payload = encode_payload(body)
            self._last[pk] = (body, payload)
        return encode_with_payload(interf, index, _DATA, subtype, payload,
                                   timestamp=timestamp, robot=robot)
