"""The message table: (interface, type, subtype) -> body class (``None`` = empty body).

Replies (RESP_ACK, RESP_NACK) use the table of the matching REQ, as Player does. The
universal property requests (subtypes 247-255) are valid on every interface.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import imu_msgs as imu
from player_server.protocol import player_msgs as pm
from player_server.protocol import sensor_msgs as sm
from player_server.protocol import simulation_msgs as simm
from player_server.protocol.constants import Interface as If
from player_server.protocol.constants import MsgType as T

Key = tuple[int, int, int]

_DATA, _CMD, _REQ, _SYNCH = int(T.DATA), int(T.CMD), int(T.REQ), int(T.SYNCH)

_TABLE: dict[Key, Any] = {
    # player
    (If.PLAYER, _REQ, c.PLAYER_REQ_DEVLIST): pm.DeviceDevlist,
    (If.PLAYER, _REQ, c.PLAYER_REQ_DRIVERINFO): pm.DeviceDriverInfo,
    (If.PLAYER, _REQ, c.PLAYER_REQ_DEV): pm.DeviceReq,
    (If.PLAYER, _REQ, c.PLAYER_REQ_DATA): None,
    (If.PLAYER, _REQ, c.PLAYER_REQ_DATAMODE): pm.DeviceDatamodeReq,
    (If.PLAYER, _REQ, c.PLAYER_REQ_AUTH): pm.DeviceAuthReq,
    (If.PLAYER, _REQ, c.PLAYER_REQ_NAMESERVICE): pm.DeviceNameserviceReq,
    (If.PLAYER, _REQ, c.PLAYER_REQ_ADD_REPLACE_RULE): pm.AddReplaceRuleReq,
    (If.PLAYER, _SYNCH, c.PLAYER_SYNCH_OK): None,
    (If.PLAYER, _SYNCH, c.PLAYER_SYNCH_OVERFLOW): pm.SynchOverflow,
    # opaque
    (If.OPAQUE, _DATA, c.PLAYER_OPAQUE_DATA_STATE): sm.OpaqueData,
    (If.OPAQUE, _CMD, c.PLAYER_OPAQUE_CMD_DATA): sm.OpaqueData,
    (If.OPAQUE, _REQ, c.PLAYER_OPAQUE_REQ_DATA): sm.OpaqueData,
    # power
    (If.POWER, _DATA, c.PLAYER_POWER_DATA_STATE): am.PowerData,
    (If.POWER, _REQ, c.PLAYER_POWER_REQ_SET_CHARGING_POLICY): am.PowerChargePolicyConfig,
    # gripper
    (If.GRIPPER, _DATA, c.PLAYER_GRIPPER_DATA_STATE): am.GripperData,
    (If.GRIPPER, _REQ, c.PLAYER_GRIPPER_REQ_GET_GEOM): am.GripperGeom,
    (If.GRIPPER, _CMD, c.PLAYER_GRIPPER_CMD_OPEN): None,
    (If.GRIPPER, _CMD, c.PLAYER_GRIPPER_CMD_CLOSE): None,
    (If.GRIPPER, _CMD, c.PLAYER_GRIPPER_CMD_STOP): None,
    (If.GRIPPER, _CMD, c.PLAYER_GRIPPER_CMD_STORE): None,
    (If.GRIPPER, _CMD, c.PLAYER_GRIPPER_CMD_RETRIEVE): None,
    # position2d
    (If.POSITION2D, _DATA, c.PLAYER_POSITION2D_DATA_STATE): am.Position2dData,
    (If.POSITION2D, _DATA, c.PLAYER_POSITION2D_DATA_GEOM): am.Position2dGeom,
    (If.POSITION2D, _CMD, c.PLAYER_POSITION2D_CMD_VEL): am.Position2dCmdVel,
    (If.POSITION2D, _CMD, c.PLAYER_POSITION2D_CMD_POS): am.Position2dCmdPos,
    (If.POSITION2D, _CMD, c.PLAYER_POSITION2D_CMD_CAR): am.Position2dCmdCar,
    (If.POSITION2D, _CMD, c.PLAYER_POSITION2D_CMD_VEL_HEAD): am.Position2dCmdVelHead,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_GET_GEOM): am.Position2dGeom,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_MOTOR_POWER): am.Position2dPowerConfig,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_VELOCITY_MODE):
        am.Position2dVelocityModeConfig,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_POSITION_MODE): am.Position2dPositionModeReq,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_SET_ODOM): am.Position2dSetOdomReq,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_RESET_ODOM): None,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_SPEED_PID): am.Position2dPidReq,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_POSITION_PID): am.Position2dPidReq,
    (If.POSITION2D, _REQ, c.PLAYER_POSITION2D_REQ_SPEED_PROF): am.Position2dSpeedProfReq,
    # sonar
    (If.SONAR, _DATA, c.PLAYER_SONAR_DATA_RANGES): sm.SonarData,
    (If.SONAR, _DATA, c.PLAYER_SONAR_DATA_GEOM): sm.SonarGeom,
    (If.SONAR, _REQ, c.PLAYER_SONAR_REQ_GET_GEOM): sm.SonarGeom,
    (If.SONAR, _REQ, c.PLAYER_SONAR_REQ_POWER): sm.SonarPowerConfig,
    # laser
    (If.LASER, _DATA, c.PLAYER_LASER_DATA_SCAN): sm.LaserData,
    (If.LASER, _DATA, c.PLAYER_LASER_DATA_SCANPOSE): sm.LaserDataScanpose,
    (If.LASER, _DATA, c.PLAYER_LASER_DATA_SCANANGLE): sm.LaserDataScanangle,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_GET_GEOM): sm.LaserGeom,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_SET_CONFIG): sm.LaserConfig,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_GET_CONFIG): sm.LaserConfig,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_POWER): sm.LaserPowerConfig,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_GET_ID): sm.LaserGetIdConfig,
    (If.LASER, _REQ, c.PLAYER_LASER_REQ_SET_FILTER): sm.LaserSetFilterConfig,
    # blobfinder
    (If.BLOBFINDER, _DATA, c.PLAYER_BLOBFINDER_DATA_BLOBS): sm.BlobfinderData,
    (If.BLOBFINDER, _REQ, c.PLAYER_BLOBFINDER_REQ_SET_COLOR): sm.BlobfinderColorConfig,
    (If.BLOBFINDER, _REQ, c.PLAYER_BLOBFINDER_REQ_SET_IMAGER_PARAMS):
        sm.BlobfinderImagerConfig,
    (If.BLOBFINDER, _REQ, c.PLAYER_BLOBFINDER_REQ_GET_COLOR): sm.BlobfinderColorConfig,
    # ptz
    (If.PTZ, _DATA, c.PLAYER_PTZ_DATA_STATE): am.PtzData,
    (If.PTZ, _CMD, c.PLAYER_PTZ_CMD_STATE): am.PtzCmd,
    (If.PTZ, _REQ, c.PLAYER_PTZ_REQ_GENERIC): am.PtzReqGeneric,
    (If.PTZ, _REQ, c.PLAYER_PTZ_REQ_CONTROL_MODE): am.PtzReqControlMode,
    (If.PTZ, _REQ, c.PLAYER_PTZ_REQ_GEOM): am.PtzGeom,
    (If.PTZ, _REQ, c.PLAYER_PTZ_REQ_STATUS): am.PtzReqStatus,
    # fiducial
    (If.FIDUCIAL, _DATA, c.PLAYER_FIDUCIAL_DATA_SCAN): sm.FiducialData,
    (If.FIDUCIAL, _REQ, c.PLAYER_FIDUCIAL_REQ_GET_GEOM): sm.FiducialGeom,
    (If.FIDUCIAL, _REQ, c.PLAYER_FIDUCIAL_REQ_GET_FOV): sm.FiducialFov,
    (If.FIDUCIAL, _REQ, c.PLAYER_FIDUCIAL_REQ_SET_FOV): sm.FiducialFov,
    (If.FIDUCIAL, _REQ, c.PLAYER_FIDUCIAL_REQ_GET_ID): sm.FiducialId,
    (If.FIDUCIAL, _REQ, c.PLAYER_FIDUCIAL_REQ_SET_ID): sm.FiducialId,
    # bumper
    (If.BUMPER, _DATA, c.PLAYER_BUMPER_DATA_STATE): sm.BumperData,
    (If.BUMPER, _DATA, c.PLAYER_BUMPER_DATA_GEOM): sm.BumperGeom,
    (If.BUMPER, _REQ, c.PLAYER_BUMPER_REQ_GET_GEOM): sm.BumperGeom,
    # simulation (no DATA)
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_GET_POSE2D): simm.SimulationPose2dReq,
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_SET_POSE2D): simm.SimulationPose2dReq,
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_GET_POSE3D): simm.SimulationPose3dReq,
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_SET_POSE3D): simm.SimulationPose3dReq,
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_GET_PROPERTY): simm.SimulationPropertyReq,
    (If.SIMULATION, _REQ, c.PLAYER_SIMULATION_REQ_SET_PROPERTY): simm.SimulationPropertyReq,
    (If.SIMULATION, _CMD, c.PLAYER_SIMULATION_CMD_PAUSE): None,
    (If.SIMULATION, _CMD, c.PLAYER_SIMULATION_CMD_RESET): None,
    (If.SIMULATION, _CMD, c.PLAYER_SIMULATION_CMD_SAVE): None,
    # camera
    (If.CAMERA, _DATA, c.PLAYER_CAMERA_DATA_STATE): sm.CameraData,
    (If.CAMERA, _REQ, c.PLAYER_CAMERA_REQ_GET_SOURCE): sm.CameraSourceReq,
    (If.CAMERA, _REQ, c.PLAYER_CAMERA_REQ_SET_SOURCE): sm.CameraSourceReq,
    (If.CAMERA, _REQ, c.PLAYER_CAMERA_REQ_GET_IMAGE): sm.CameraData,
    # imu
    (If.IMU, _DATA, c.PLAYER_IMU_DATA_STATE): imu.ImuDataState,
    (If.IMU, _DATA, c.PLAYER_IMU_DATA_CALIB): imu.ImuDataCalib,
    (If.IMU, _DATA, c.PLAYER_IMU_DATA_QUAT): imu.ImuDataQuat,
    (If.IMU, _DATA, c.PLAYER_IMU_DATA_EULER): imu.ImuDataEuler,
    (If.IMU, _DATA, c.PLAYER_IMU_DATA_FULLSTATE): imu.ImuDataFullstate,
    (If.IMU, _REQ, c.PLAYER_IMU_REQ_SET_DATATYPE): imu.ImuDatatypeConfig,
    (If.IMU, _REQ, c.PLAYER_IMU_REQ_RESET_ORIENTATION): imu.ImuResetOrientationConfig,
    # ranger
    (If.RANGER, _DATA, c.PLAYER_RANGER_DATA_RANGE): sm.RangerDataRange,
    (If.RANGER, _DATA, c.PLAYER_RANGER_DATA_RANGESTAMPED): sm.RangerDataRangestamped,
    (If.RANGER, _DATA, c.PLAYER_RANGER_DATA_INTNS): sm.RangerDataIntns,
    (If.RANGER, _DATA, c.PLAYER_RANGER_DATA_INTNSSTAMPED): sm.RangerDataIntnsstamped,
    (If.RANGER, _DATA, c.PLAYER_RANGER_DATA_GEOM): sm.RangerGeom,
    (If.RANGER, _REQ, c.PLAYER_RANGER_REQ_GET_GEOM): sm.RangerGeom,
    (If.RANGER, _REQ, c.PLAYER_RANGER_REQ_POWER): sm.RangerPowerConfig,
    (If.RANGER, _REQ, c.PLAYER_RANGER_REQ_INTNS): sm.RangerPowerConfig,
    (If.RANGER, _REQ, c.PLAYER_RANGER_REQ_SET_CONFIG): sm.RangerConfig,
    (If.RANGER, _REQ, c.PLAYER_RANGER_REQ_GET_CONFIG): sm.RangerConfig,
}

UNIVERSAL_REQUESTS: Mapping[int, Any] = MappingProxyType({
    c.PLAYER_CAPABILITIES_REQ: pm.CapabilitiesReq,
    c.PLAYER_GET_INTPROP_REQ: pm.IntPropReq,
    c.PLAYER_SET_INTPROP_REQ: pm.IntPropReq,
    c.PLAYER_GET_DBLPROP_REQ: pm.DblPropReq,
    c.PLAYER_SET_DBLPROP_REQ: pm.DblPropReq,
    c.PLAYER_GET_STRPROP_REQ: pm.StrPropReq,
    c.PLAYER_SET_STRPROP_REQ: pm.StrPropReq,
    c.PLAYER_GET_BOOLPROP_REQ: pm.BoolPropReq,
    c.PLAYER_SET_BOOLPROP_REQ: pm.BoolPropReq,
})

REGISTRY: Mapping[Key, Any] = MappingProxyType(
    {(int(i), int(t), int(s)): cls for (i, t, s), cls in _TABLE.items()}
)

_REPLY_TYPES = (int(T.RESP_ACK), int(T.RESP_NACK))


class UnknownMessage(KeyError):
    """No declaration for this (interface, type, subtype)."""


def lookup(interf: int, msg_type: int, subtype: int) -> Any:
    """Body class of a message (``None`` for a declared empty body).

    Raises ``UnknownMessage`` when the triple is not declared.
    """
    table_type = _REQ if msg_type in _REPLY_TYPES else msg_type
    key = (interf, table_type, subtype)
    try:
        return REGISTRY[key]
    except KeyError:
        pass
    if table_type == _REQ and subtype in UNIVERSAL_REQUESTS:
        return UNIVERSAL_REQUESTS[subtype]
    raise UnknownMessage(key)


def is_declared(interf: int, msg_type: int, subtype: int) -> bool:
    try:
        lookup(interf, msg_type, subtype)
    except UnknownMessage:
        return False
    return True


def subtypes(interf: int, msg_type: int) -> tuple[int, ...]:
    """Declared subtypes of one interface and message type."""
    return tuple(sorted(s for (i, t, s) in REGISTRY if i == interf and t == msg_type))
