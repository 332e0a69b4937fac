"""Bodies of the simulation interface (code 31). It has no DATA messages."""

from __future__ import annotations

from typing import Annotated

from player_server.protocol.common import POSE2D_ZERO, POSE3D_ZERO, Pose2d, Pose3d
from player_server.protocol.xdr import F64, U32, ByteArray, String, xdr_dataclass

SimName = Annotated[str, String(1024)]


@xdr_dataclass
class SimulationPose2dReq:
    """REQ 1 GET_POSE2D / REQ 2 SET_POSE2D: an object's name and pose."""

    name: SimName = ""
    pose: Pose2d = POSE2D_ZERO


@xdr_dataclass
class SimulationPose3dReq:
    """REQ 3 GET_POSE3D / REQ 4 SET_POSE3D."""

    name: SimName = ""
    pose: Pose3d = POSE3D_ZERO
    simtime: F64 = 0.0


@xdr_dataclass
class SimulationPropertyReq:
    """REQ 5 GET_PROPERTY / REQ 6 SET_PROPERTY (value: raw bytes)."""

    name: SimName = ""
    prop: SimName = ""
    index: U32 = 0
    value: ByteArray = b""
