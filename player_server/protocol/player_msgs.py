"""Bodies of the ``player`` interface (code 1) and the universal property requests."""

from __future__ import annotations

from typing import Annotated

from player_server.protocol.common import DEVADDR_ZERO, DevAddr
from player_server.protocol.xdr import (
    F64,
    I32,
    U8,
    U16,
    U32,
    Array,
    Bytes,
    String,
    xdr_dataclass,
)

DriverName = Annotated[str, String(64)]
PropKey = Annotated[str, String(1024)]
PropText = Annotated[str, String(65536)]


@xdr_dataclass
class DeviceDevlist:
    """REQ 1 DEVLIST reply: the devices behind this port (max 4096)."""

    devices: Annotated[tuple[DevAddr, ...], Array(DevAddr, 4096)] = ()


@xdr_dataclass
class DeviceDriverInfo:
    """REQ 2 DRIVERINFO request and reply."""

    addr: DevAddr = DEVADDR_ZERO
    driver_name: DriverName = ""


@xdr_dataclass
class DeviceReq:
    """REQ 3 DEV: subscribe (access 1) / unsubscribe (2); reply grants access, names driver."""

    addr: DevAddr = DEVADDR_ZERO
    access: U8 = 0
    driver_name: DriverName = ""


@xdr_dataclass
class DeviceDatamodeReq:
    """REQ 5 DATAMODE: PUSH 1, PULL 2."""

    mode: U8 = 0


@xdr_dataclass
class DeviceAuthReq:
    """REQ 7 AUTH (answered with NACK)."""

    auth_key: Annotated[bytes, Bytes(32)] = b""


@xdr_dataclass
class DeviceNameserviceReq:
    """REQ 8 NAMESERVICE (answered with NACK)."""

    name: Annotated[bytes, Bytes(64)] = b""
    port: U16 = 0


@xdr_dataclass
class AddReplaceRuleReq:
    """REQ 10 ADD_REPLACE_RULE; -1 is a wildcard; replace: 0 ACCEPT, 1 REPLACE, 2 IGNORE."""

    interf: I32 = -1
    index: I32 = -1
    type: I32 = -1
    subtype: I32 = -1
    replace: I32 = 0


@xdr_dataclass
class SynchOverflow:
    """SYNCH 2 OVERFLOW: number of messages dropped."""

    dropped: U32 = 0


@xdr_dataclass
class CapabilitiesReq:
    """Universal REQ 255: is (type, subtype) supported?"""

    type: U32 = 0
    subtype: U32 = 0


@xdr_dataclass
class IntPropReq:
    """Universal REQ 254/253 GET/SET_INTPROP."""

    key: PropKey = ""
    value: I32 = 0


@xdr_dataclass
class DblPropReq:
    """Universal REQ 252/251 GET/SET_DBLPROP."""

    key: PropKey = ""
    value: F64 = 0.0


@xdr_dataclass
class StrPropReq:
    """Universal REQ 250/249 GET/SET_STRPROP."""

    key: PropKey = ""
    value: PropText = ""


@xdr_dataclass
class BoolPropReq:
    """Universal REQ 248/247 GET/SET_BOOLPROP (value is a char on the wire)."""

    key: PropKey = ""
    value: U8 = 0


__all__ = [
    "AddReplaceRuleReq",
    "BoolPropReq",
    "CapabilitiesReq",
    "DblPropReq",
    "DeviceAuthReq",
    "DeviceDatamodeReq",
    "DeviceDevlist",
    "DeviceDriverInfo",
    "DeviceNameserviceReq",
    "DeviceReq",
    "IntPropReq",
    "StrPropReq",
    "SynchOverflow",
]
