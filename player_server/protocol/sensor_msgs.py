"""Bodies of the sensing interfaces: sonar, laser, blobfinder, fiducial, bumper, camera, ranger."""

from __future__ import annotations

from typing import Annotated

from player_server.protocol.common import (
    BBOX2D_ZERO,
    BBOX3D_ZERO,
    POSE2D_ZERO,
    POSE3D_ZERO,
    Bbox2d,
    Bbox3d,
    Pose2d,
    Pose3d,
)
from player_server.protocol.xdr import (
    F32,
    F64,
    I32,
    U8,
    U32,
    WIRE_F32,
    Array,
    ByteArray,
    F32Array,
    F64Array,
    String,
    xdr_dataclass,
)


@xdr_dataclass
class SonarData:
    """sonar DATA 1 RANGES [m]."""

    ranges: F32Array = ()


@xdr_dataclass
class SonarGeom:
    """sonar GET_GEOM reply / DATA 2: one pose per transducer (robot frame)."""

    poses: Annotated[tuple[Pose3d, ...], Array(Pose3d)] = ()


@xdr_dataclass
class SonarPowerConfig:
    """sonar REQ 2 POWER."""

    state: U8 = 0


@xdr_dataclass
class LaserData:
    """laser DATA 1 SCAN; bearing i = min_angle + i * resolution."""

    min_angle: F32 = 0.0
    max_angle: F32 = 0.0
    resolution: F32 = 0.0
    max_range: F32 = 0.0
    ranges: F32Array = ()
    intensity: ByteArray = b""
    id: U32 = 0


@xdr_dataclass
class LaserDataScanpose:
    """laser DATA 2 SCANPOSE: a scan and the laser pose when scanned."""

    scan: LaserData = LaserData()
    pose: Pose2d = POSE2D_ZERO


@xdr_dataclass
class LaserDataScanangle:
    """laser DATA 3 SCANANGLE: explicit bearings."""

    max_range: F32 = 0.0
    ranges: F32Array = ()
    angles: F32Array = ()
    intensity: ByteArray = b""
    id: U32 = 0


@xdr_dataclass
class LaserGeom:
    """laser REQ 1 GET_GEOM reply."""

    pose: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO


@xdr_dataclass
class LaserConfig:
    """laser REQ 2 SET_CONFIG / REQ 3 GET_CONFIG."""

    min_angle: F32 = 0.0
    max_angle: F32 = 0.0
    resolution: F32 = 0.0
    max_range: F32 = 0.0
    range_res: F32 = 0.0
    intensity: U8 = 0
    scanning_frequency: F32 = 0.0


@xdr_dataclass
class LaserPowerConfig:
    """laser REQ 4 POWER."""

    state: U8 = 0


@xdr_dataclass
class LaserGetIdConfig:
    """laser REQ 5 GET_ID reply."""

    serial_number: U32 = 0


@xdr_dataclass
class LaserSetFilterConfig:
    """laser REQ 6 SET_FILTER (types MEDIAN 1, EDGE 2, RANGE 3, MEAN 4)."""

    filter_type: U8 = 0
    parameters: Annotated[tuple[float, ...], Array(WIRE_F32, 8)] = ()


@xdr_dataclass
class BlobfinderBlob:
    """One blob (40 B): colour 0x00RRGGBB, area and box in pixels, range in metres."""

    id: U32 = 0
    color: U32 = 0
    area: U32 = 0
    x: U32 = 0
    y: U32 = 0
    left: U32 = 0
    right: U32 = 0
    top: U32 = 0
    bottom: U32 = 0
    range: F32 = 0.0


@xdr_dataclass
class BlobfinderData:
    """blobfinder DATA 1 BLOBS."""

    width: U32 = 0
    height: U32 = 0
    blobs: Annotated[tuple[BlobfinderBlob, ...], Array(BlobfinderBlob)] = ()


@xdr_dataclass
class BlobfinderColorConfig:
    """blobfinder REQ 1 SET_COLOR / REQ 3 GET_COLOR."""

    channel: U32 = 0
    rmin: U32 = 0
    rmax: U32 = 0
    gmin: U32 = 0
    gmax: U32 = 0
    bmin: U32 = 0
    bmax: U32 = 0


@xdr_dataclass
class BlobfinderImagerConfig:
    """blobfinder REQ 2 SET_IMAGER_PARAMS."""

    brightness: I32 = 0
    contrast: I32 = 0
    colormode: I32 = 0
    autogain: I32 = 0


@xdr_dataclass
class FiducialItem:
    """One fiducial (100 B): id (-1 unidentified), pose relative to the detector, uncertainty."""

    id: I32 = -1
    pose: Pose3d = POSE3D_ZERO
    upose: Pose3d = POSE3D_ZERO


@xdr_dataclass
class FiducialData:
    """fiducial DATA 1 SCAN."""

    fiducials: Annotated[tuple[FiducialItem, ...], Array(FiducialItem)] = ()


@xdr_dataclass
class FiducialGeom:
    """fiducial REQ 1 GET_GEOM reply."""

    pose: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO
    fiducial_size: Bbox2d = BBOX2D_ZERO


@xdr_dataclass
class FiducialFov:
    """fiducial REQ 2 GET_FOV / REQ 3 SET_FOV."""

    min_range: F32 = 0.0
    max_range: F32 = 0.0
    view_angle: F32 = 0.0


@xdr_dataclass
class FiducialId:
    """fiducial REQ 7 GET_ID / REQ 8 SET_ID."""

    id: U32 = 0


@xdr_dataclass
class BumperData:
    """bumper DATA 1 STATE: one byte per bumper, nonzero = pressed."""

    bumpers: ByteArray = b""


@xdr_dataclass
class BumperDefine:
    """One bumper (56 B): pose, length, radius (0 = straight)."""

    pose: Pose3d = POSE3D_ZERO
    length: F32 = 0.0
    radius: F32 = 0.0


@xdr_dataclass
class BumperGeom:
    """bumper GET_GEOM reply / DATA 2 GEOM."""

    bumper_def: Annotated[tuple[BumperDefine, ...], Array(BumperDefine)] = ()


@xdr_dataclass
class OpaqueData:
    """opaque DATA 1 STATE, CMD 2 DATA and REQ 1 DATA: application-defined bytes."""

    data: ByteArray = b""


@xdr_dataclass
class CameraData:
    """camera DATA 1 STATE and REQ 3 GET_IMAGE reply."""

    width: U32 = 0
    height: U32 = 0
    bpp: U32 = 0
    format: U32 = 0
    fdiv: U32 = 0
    compression: U32 = 0
    image: ByteArray = b""


@xdr_dataclass
class CameraSourceReq:
    """camera REQ 1 GET_SOURCE / REQ 2 SET_SOURCE."""

    norm: Annotated[str, String(16)] = ""
    source: I32 = 0


@xdr_dataclass
class RangerDataRange:
    """ranger DATA 1 RANGE [m]."""

    ranges: F64Array = ()


@xdr_dataclass
class RangerDataIntns:
    """ranger DATA 3 INTNS."""

    intensities: F64Array = ()


@xdr_dataclass
class RangerGeom:
    """ranger GET_GEOM reply / DATA 5 GEOM."""

    pose: Pose3d = POSE3D_ZERO
    size: Bbox3d = BBOX3D_ZERO
    element_poses: Annotated[tuple[Pose3d, ...], Array(Pose3d)] = ()
    element_sizes: Annotated[tuple[Bbox3d, ...], Array(Bbox3d)] = ()


@xdr_dataclass
class RangerConfig:
    """ranger REQ 4 SET_CONFIG / REQ 5 GET_CONFIG (rad, m, Hz)."""

    min_angle: F64 = 0.0
    max_angle: F64 = 0.0
    angular_res: F64 = 0.0
    min_range: F64 = 0.0
    max_range: F64 = 0.0
    range_res: F64 = 0.0
    frequency: F64 = 0.0


@xdr_dataclass
class RangerDataRangestamped:
    """ranger DATA 2 RANGESTAMPED; geom and config are always encoded."""

    data: RangerDataRange = RangerDataRange()
    have_geom: U8 = 0
    geom: RangerGeom = RangerGeom()
    have_config: U8 = 0
    config: RangerConfig = RangerConfig()


@xdr_dataclass
class RangerDataIntnsstamped:
    """ranger DATA 4 INTNSSTAMPED."""

    data: RangerDataIntns = RangerDataIntns()
    have_geom: U8 = 0
    geom: RangerGeom = RangerGeom()
    have_config: U8 = 0
    config: RangerConfig = RangerConfig()


@xdr_dataclass
class RangerPowerConfig:
    """ranger REQ 2 POWER / REQ 3 INTNS."""

    state: U8 = 0

