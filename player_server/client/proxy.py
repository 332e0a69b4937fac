"""The proxy base class: a subscribed device seen from the client."""

from __future__ import annotations

from typing import Any, ClassVar, Protocol

from player_server.client.errors import PlayerNack
from player_server.client.framing import decode_frame
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol.codec import Undecodable
from player_server.protocol.errors import DecodeError


class ClientLink(Protocol):
    """What a proxy asks of its client (`connection.PlayerClient` is one)."""

    def request(self, interf: int, index: int, subtype: int, body: Any = None,
                timeout_s: float | None = None) -> Any: ...

    def command(self, interf: int, index: int, subtype: int, body: Any = None) -> None: ...

    def clock(self) -> float:
        """The client's clock (seconds), which stamps what it sends."""
        ...

    def send_encoded(self, wire: bytes, *, defer: bool = False) -> None: ...



_DATA = int(c.MsgType.DATA)
#: DATA bodies up to this size are kept with what they decoded to (`Proxy._on_raw`)
_KEEP_BYTES = 4096


class Proxy:
    """Latest values of one device plus its requests and commands.

    Subclasses set ``interf`` and keep each DATA body they understand in an attribute
    (frozen values, replaced and never mutated, so other threads may read them).
    ``data_time_s`` is the simulation time of the latest DATA, ``data_count`` how many
    arrived.

    The client hands each DATA body over as it lies in the receive buffer
    (``_on_raw``); by default it is decoded into its message class and stored by
    ``_update``. Proxies of the devices read every tick take their common bodies
    straight into tuples of values instead and build the message objects only when
    asked for them.
    """

    interf: ClassVar[int] = 0

    def __init__(self, client: ClientLink, index: int = 0) -> None:
        self.client = client
        self.index = index
        self.driver_name = ""
        self.data_time_s: float | None = None
        self.data_count = 0
        # per DATA subtype, the last body's bytes and what they decoded to: a device whose
        # reading did not change sends the same bytes every round (a team clock table, a
        # gripper, a PTZ at rest), and decoding them again would make the same frozen body
        self._decoded: dict[int, tuple[bytes, Any]] = {}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {c.interface_name(self.interf)}:{self.index}>"

    @property
    def fresh(self) -> bool:
        """True once at least one DATA has arrived."""
        return self.data_count > 0

    def _on_data(self, subtype: int, body: Any, timestamp: float) -> None:
        self.data_time_s = timestamp
        self.data_count += 1
        self._update(subtype, body)

    def _update(self, subtype: int, body: Any) -> None:
        """Store one DATA body (override)."""

    def _on_raw(self, subtype: int, buf: Any, start: int, end: int, timestamp: float) -> None:
        """Take one DATA body from ``buf[start:end]`` (valid only during this call).

        Raises ``DecodeError`` when it does not decode; nothing is stored then.
        """
        small = end - start <= _KEEP_BYTES  # (an image is neither kept nor compared)
        if small:
            raw = buf[start:end]  # (compared as it is; made bytes only when kept)
            known = self._decoded.get(subtype)
            if known is not None and known[0] == raw:
                self._on_data(subtype, known[1], timestamp)
                return
        msg = decode_frame((0, 0, self.interf, self.index, _DATA, subtype,
                            timestamp, 0, end - start), buf, start, end)
        if isinstance(msg, Undecodable):
            raise DecodeError(msg.reason)
        if small:
            self._decoded[subtype] = (bytes(raw), msg.body)
        self._on_data(subtype, msg.body, timestamp)

    # -- requests and commands ----------------------------------------------------------------
    def request(self, subtype: int, body: Any = None, timeout_s: float | None = None) -> Any:
        return self.client.request(self.interf, self.index, subtype, body, timeout_s)

    def command(self, subtype: int, body: Any = None) -> None:
        self.client.command(self.interf, self.index, subtype, body)

    def capable(self, msg_type: int, subtype: int) -> bool:
        try:
            self.request(c.PLAYER_CAPABILITIES_REQ, pm.CapabilitiesReq(msg_type, subtype))
        except PlayerNack:
            return False
        return True

    def get_int_prop(self, key: str) -> int:
        return int(self.request(c.PLAYER_GET_INTPROP_REQ, pm.IntPropReq(key, 0)).value)

    def set_int_prop(self, key: str, value: int) -> None:
        self.request(c.PLAYER_SET_INTPROP_REQ, pm.IntPropReq(key, value))

    def get_dbl_prop(self, key: str) -> float:
        return float(self.request(c.PLAYER_GET_DBLPROP_REQ, pm.DblPropReq(key, 0.0)).value)

    def set_dbl_prop(self, key: str, value: float) -> None:
        self.request(c.PLAYER_SET_DBLPROP_REQ, pm.DblPropReq(key, value))

    def get_str_prop(self, key: str) -> str:
        return str(self.request(c.PLAYER_GET_STRPROP_REQ, pm.StrPropReq(key, "")).value)

    def set_str_prop(self, key: str, value: str) -> None:
        self.request(c.PLAYER_SET_STRPROP_REQ, pm.StrPropReq(key, value))

    def get_bool_prop(self, key: str) -> bool:
        return bool(self.request(c.PLAYER_GET_BOOLPROP_REQ, pm.BoolPropReq(key, 0)).value)

    def set_bool_prop(self, key: str, value: bool) -> None:
        self.request(c.PLAYER_SET_BOOLPROP_REQ, pm.BoolPropReq(key, int(value)))
