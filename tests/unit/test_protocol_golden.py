"""Golden bytes for every message the server sends or accepts, both ways.

Expected bodies are written with a tiny independent XDR writer (``W``) that spells out
the wire rules (4-byte widening, counts written twice, byte arrays padded to 4), and a
few messages are checked against literal bytes from the protocol reference.
"""

from __future__ import annotations

import struct
from typing import Any

import pytest

from player_server.protocol import NEED_DATA, Decoder, Message, encode_message
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import imu_msgs as imu
from player_server.protocol import player_msgs as pm
from player_server.protocol import sensor_msgs as sm
from player_server.protocol import simulation_msgs as simm
from player_server.protocol.common import Bbox2d, Bbox3d, DevAddr, Pose2d, Pose3d
from player_server.protocol.registry import REGISTRY, UNIVERSAL_REQUESTS


class W:
    """Independent big-endian XDR writer used to state expected bytes."""

    def __init__(self) -> None:
        self.b = b""

    def u(self, *v: int) -> W:
        for x in v:
            self.b += struct.pack(">I", x)
        return self

    def i(self, *v: int) -> W:
        for x in v:
            self.b += struct.pack(">i", x)
        return self

    def f(self, *v: float) -> W:
        for x in v:
            self.b += struct.pack(">f", x)
        return self

    def d(self, *v: float) -> W:
        for x in v:
            self.b += struct.pack(">d", x)
        return self

    def raw(self, data: bytes) -> W:
        n = len(data)
        self.b += struct.pack(">II", n, n) + data + b"\0" * ((4 - n % 4) % 4)
        return self

    def s(self, text: str) -> W:
        return self.raw(text.encode() + b"\0" if text else b"")


P2 = Pose2d(1.5, -2.25, 0.5)
P3 = Pose3d(0.1, 0.2, 0.3, 0.0, 0.25, -1.0)
B3 = Bbox3d(0.5, 0.75, 0.25)


def p2(w: W) -> W:
    return w.d(1.5, -2.25, 0.5)


def p3(w: W) -> W:
    return w.d(0.1, 0.2, 0.3, 0.0, 0.25, -1.0)


def b3(w: W) -> W:
    return w.d(0.5, 0.75, 0.25)


RG = sm.RangerGeom(P3, B3, (P3,), (B3,))
RC = sm.RangerConfig(-1.5, 1.5, 0.5, 0.0, 5.0, 0.01, 10.0)


def rg(w: W) -> W:
    return b3(p3(b3(p3(w)).u(1, 1)).u(1, 1))


def rc(w: W) -> W:
    return w.d(-1.5, 1.5, 0.5, 0.0, 5.0, 0.01, 10.0)


CAL_VALUES = (0.5, -0.25, 9.75, 0.0, 0.0, 1.5, 0.125, 0.0, -0.5)
CAL = imu.ImuDataCalib(*CAL_VALUES)

D, CM, R, S = 1, 2, 3, 5
CASES: list[tuple[str, int, int, int, Any, bytes]] = [
    ("devlist", 1, R, 1, pm.DeviceDevlist((DevAddr(0, 6665, 4, 0), DevAddr(0, 6665, 6, 0))),
     W().u(2, 2, 0, 6665, 4, 0, 0, 6665, 6, 0).b),
    ("driverinfo", 1, R, 2, pm.DeviceDriverInfo(DevAddr(0, 0, 6, 0), "sim_laser"),
     W().u(0, 0, 6, 0).s("sim_laser").b),
    ("dev", 1, R, 3, pm.DeviceReq(DevAddr(0, 0, 4, 0), 1, ""), W().u(0, 0, 4, 0, 1, 0, 0).b),
    ("datamode", 1, R, 5, pm.DeviceDatamodeReq(2), W().u(2).b),
    ("auth", 1, R, 7, pm.DeviceAuthReq(b"key"), W().raw(b"key").b),
    ("nameservice", 1, R, 8, pm.DeviceNameserviceReq(b"x\0", 6665), W().raw(b"x\0").u(6665).b),
    ("replace_rule", 1, R, 10, pm.AddReplaceRuleReq(-1, -1, 1, -1, 1),
     W().i(-1, -1, 1, -1, 1).b),
    ("synch_overflow", 1, S, 2, pm.SynchOverflow(3), W().u(3).b),
    ("capabilities", 4, R, 255, pm.CapabilitiesReq(2, 1), W().u(2, 1).b),
    ("intprop", 6, R, 254, pm.IntPropReq("k", -3), W().s("k").i(-3).b),
    ("set_intprop", 1, R, 253, pm.IntPropReq("lockstep", 1), W().s("lockstep").i(1).b),
    ("dblprop", 6, R, 252, pm.DblPropReq("max_speed", 0.5), W().s("max_speed").d(0.5).b),
    ("set_dblprop", 6, R, 251, pm.DblPropReq("a", 1.0), W().s("a").d(1.0).b),
    ("strprop", 6, R, 250, pm.StrPropReq("name", "r1"), W().s("name").s("r1").b),
    ("set_strprop", 6, R, 249, pm.StrPropReq("name", "r2"), W().s("name").s("r2").b),
    ("boolprop", 6, R, 248, pm.BoolPropReq("on", 1), W().s("on").u(1).b),
    ("set_boolprop", 6, R, 247, pm.BoolPropReq("on", 0), W().s("on").u(0).b),
    ("power", 2, D, 1, am.PowerData(31, 12.5, 80.0, 1000.0, -2.5, 1),
     W().u(31).f(12.5, 80.0, 1000.0, -2.5).i(1).b),
    ("charging_policy", 2, R, 1, am.PowerChargePolicyConfig(1, 0), W().u(1, 0).b),
    ("gripper", 3, D, 1, am.GripperData(2, 3, 1), W().u(2, 3, 1).b),
    ("gripper_geom", 3, R, 1, am.GripperGeom(P3, B3, B3, 2, 1),
     b3(b3(p3(W()))).u(2, 1).b),
    ("pos2d_state", 4, D, 1, am.Position2dData(P2, Pose2d(0.25, 0.0, -0.5), 1),
     p2(W()).d(0.25, 0.0, -0.5).u(1).b),
    ("pos2d_geom_data", 4, D, 2, am.Position2dGeom(P3, B3), b3(p3(W())).b),
    ("pos2d_vel", 4, CM, 1, am.Position2dCmdVel(Pose2d(0.3, 0.0, 0.1), 1),
     W().d(0.3, 0.0, 0.1).u(1).b),
    ("pos2d_pos", 4, CM, 2, am.Position2dCmdPos(P2, Pose2d(0.3, 0.0, 0.1), 1),
     p2(W()).d(0.3, 0.0, 0.1).u(1).b),
    ("pos2d_car", 4, CM, 3, am.Position2dCmdCar(0.5, 0.25), W().d(0.5, 0.25).b),
    ("pos2d_velhead", 4, CM, 4, am.Position2dCmdVelHead(0.5, 1.0), W().d(0.5, 1.0).b),
    ("pos2d_geom", 4, R, 1, am.Position2dGeom(P3, B3), b3(p3(W())).b),
    ("pos2d_motor", 4, R, 2, am.Position2dPowerConfig(1), W().u(1).b),
    ("pos2d_velmode", 4, R, 3, am.Position2dVelocityModeConfig(0), W().u(0).b),
    ("pos2d_posmode", 4, R, 4, am.Position2dPositionModeReq(1), W().u(1).b),
    ("pos2d_setodom", 4, R, 5, am.Position2dSetOdomReq(P2), p2(W()).b),
    ("pos2d_speedpid", 4, R, 7, am.Position2dPidReq(1.0, 0.5, 0.25), W().f(1.0, 0.5, 0.25).b),
    ("pos2d_pospid", 4, R, 8, am.Position2dPidReq(2.0, 0.0, 0.0), W().f(2.0, 0.0, 0.0).b),
    ("pos2d_speedprof", 4, R, 9, am.Position2dSpeedProfReq(0.5, 1.0), W().f(0.5, 1.0).b),
    ("sonar", 5, D, 1, sm.SonarData((1.0, 2.5, 5.0)), W().u(3, 3).f(1.0, 2.5, 5.0).b),
    ("sonar_geom_data", 5, D, 2, sm.SonarGeom((P3,)), p3(W().u(1, 1)).b),
    ("sonar_geom", 5, R, 1, sm.SonarGeom((P3, P3)), p3(p3(W().u(2, 2))).b),
    ("sonar_power", 5, R, 2, sm.SonarPowerConfig(1), W().u(1).b),
    ("laser", 6, D, 1, sm.LaserData(-1.5, 1.5, 0.5, 8.0, (1.0, 2.0, 0.5), b"\x01\x00\x02", 9),
     W().f(-1.5, 1.5, 0.5, 8.0).u(3, 3).f(1.0, 2.0, 0.5).raw(b"\x01\x00\x02").u(9).b),
    ("laser_scanpose", 6, D, 2,
     sm.LaserDataScanpose(sm.LaserData(0.0, 1.0, 0.5, 4.0, (1.0,), b"", 1), P2),
     p2(W().f(0.0, 1.0, 0.5, 4.0).u(1, 1).f(1.0).u(0, 0).u(1)).b),
    ("laser_scanangle", 6, D, 3, sm.LaserDataScanangle(4.0, (1.0, 2.0), (0.0, 0.5), b"", 2),
     W().f(4.0).u(2, 2).f(1.0, 2.0).u(2, 2).f(0.0, 0.5).u(0, 0).u(2).b),
    ("laser_geom", 6, R, 1, sm.LaserGeom(P3, B3), b3(p3(W())).b),
    ("laser_setcfg", 6, R, 2, sm.LaserConfig(-1.5, 1.5, 0.5, 8.0, 0.0625, 1, 10.0),
     W().f(-1.5, 1.5, 0.5, 8.0, 0.0625).u(1).f(10.0).b),
    ("laser_getcfg", 6, R, 3, sm.LaserConfig(-1.5, 1.5, 0.5, 8.0, 0.0625, 0, 10.0),
     W().f(-1.5, 1.5, 0.5, 8.0, 0.0625).u(0).f(10.0).b),
    ("laser_power", 6, R, 4, sm.LaserPowerConfig(0), W().u(0).b),
    ("laser_id", 6, R, 5, sm.LaserGetIdConfig(42), W().u(42).b),
    ("laser_filter", 6, R, 6, sm.LaserSetFilterConfig(1, (3.0,)), W().u(1, 1, 1).f(3.0).b),
    ("blobs", 7, D, 1,
     sm.BlobfinderData(80, 60, (sm.BlobfinderBlob(1, 0xFF0000, 20, 10, 11, 8, 12, 9, 13, 2.5),)),
     W().u(80, 60, 1, 1, 1, 0xFF0000, 20, 10, 11, 8, 12, 9, 13).f(2.5).b),
    ("blob_setcolor", 7, R, 1, sm.BlobfinderColorConfig(0, 1, 2, 3, 4, 5, 6),
     W().u(0, 1, 2, 3, 4, 5, 6).b),
    ("blob_imager", 7, R, 2, sm.BlobfinderImagerConfig(-1, 2, 3, 0), W().i(-1, 2, 3, 0).b),
    ("blob_getcolor", 7, R, 3, sm.BlobfinderColorConfig(0, 0, 0, 0, 0, 0, 0), W().u(*[0] * 7).b),
    ("ptz", 8, D, 1, am.PtzData(0.5, -0.25, 1.0, 0.0, 0.0, 0), W().f(0.5, -0.25, 1.0, 0, 0).u(0).b),
    ("ptz_cmd", 8, CM, 1, am.PtzCmd(0.5, 0.0, 1.0, 0.0, 0.0), W().f(0.5, 0.0, 1.0, 0, 0).b),
    ("ptz_generic", 8, R, 1, am.PtzReqGeneric((1, 2)), W().u(2, 2, 1, 2).b),
    ("ptz_mode", 8, R, 2, am.PtzReqControlMode(1), W().u(1).b),
    ("ptz_geom", 8, R, 4, am.PtzGeom(P3, B3), b3(p3(W())).b),
    ("ptz_status", 8, R, 5, am.PtzReqStatus(3), W().u(3).b),
    ("fiducial", 10, D, 1, sm.FiducialData((sm.FiducialItem(7, P3, Pose3d()),)),
     W().u(1, 1).i(7).d(0.1, 0.2, 0.3, 0.0, 0.25, -1.0).d(*[0.0] * 6).b),
    ("fiducial_geom", 10, R, 1, sm.FiducialGeom(P3, B3, Bbox2d(0.1, 0.2)),
     b3(p3(W())).d(0.1, 0.2).b),
    ("fiducial_getfov", 10, R, 2, sm.FiducialFov(0.0, 8.0, 1.5), W().f(0.0, 8.0, 1.5).b),
    ("fiducial_setfov", 10, R, 3, sm.FiducialFov(0.5, 4.0, 1.0), W().f(0.5, 4.0, 1.0).b),
    ("fiducial_getid", 10, R, 7, sm.FiducialId(3), W().u(3).b),
    ("fiducial_setid", 10, R, 8, sm.FiducialId(4), W().u(4).b),
    ("bumper", 14, D, 1, sm.BumperData(b"\x00\x01"), W().raw(b"\x00\x01").b),
    ("bumper_geom_data", 14, D, 2, sm.BumperGeom((sm.BumperDefine(P3, 0.125, 0.0),)),
     p3(W().u(1, 1)).f(0.125, 0.0).b),
    ("bumper_geom", 14, R, 1, sm.BumperGeom(()), W().u(0, 0).b),
    ("sim_getpose2d", 31, R, 1, simm.SimulationPose2dReq("robot1", Pose2d(3.0, 4.0, 0.5)),
     W().s("robot1").d(3.0, 4.0, 0.5).b),
    ("sim_setpose2d", 31, R, 2, simm.SimulationPose2dReq("box", P2), p2(W().s("box")).b),
    ("sim_getpose3d", 31, R, 3, simm.SimulationPose3dReq("r", P3, 1.5),
     p3(W().s("r")).d(1.5).b),
    ("sim_setpose3d", 31, R, 4, simm.SimulationPose3dReq("r", P3, 0.0),
     p3(W().s("r")).d(0.0).b),
    ("sim_getprop", 31, R, 5, simm.SimulationPropertyReq("r", "color", 0, b"\x01\x02\x03\x04\x05"),
     W().s("r").s("color").u(0).raw(b"\x01\x02\x03\x04\x05").b),
    ("sim_setprop", 31, R, 6, simm.SimulationPropertyReq("r", "x", 1, b""),
     W().s("r").s("x").u(1).raw(b"").b),
    ("camera", 40, D, 1, sm.CameraData(4, 2, 24, 5, 0, 0, bytes(range(24))),
     W().u(4, 2, 24, 5, 0, 0).raw(bytes(range(24))).b),
    ("camera_jpeg_odd", 40, D, 1, sm.CameraData(1, 1, 24, 5, 0, 1, b"\xff\xd8\xff"),
     W().u(1, 1, 24, 5, 0, 1).raw(b"\xff\xd8\xff").b),
    ("camera_getsrc", 40, R, 1, sm.CameraSourceReq("PAL", 1), W().s("PAL").i(1).b),
    ("opaque_state", 51, D, 1, sm.OpaqueData(b"\x01\x02\x03\x04\x05"),
     W().raw(b"\x01\x02\x03\x04\x05").b),
    ("opaque_cmd", 51, CM, 2, sm.OpaqueData(b"team"), W().raw(b"team").b),
    ("opaque_req", 51, R, 1, sm.OpaqueData(b""), W().raw(b"").b),
    ("camera_setsrc", 40, R, 2, sm.CameraSourceReq("NTSC", 0), W().s("NTSC").i(0).b),
    ("camera_getimage", 40, R, 3, sm.CameraData(1, 1, 8, 1, 0, 0, b"\x80"),
     W().u(1, 1, 8, 1, 0, 0).raw(b"\x80").b),
    ("opaque_state", 51, D, 1, sm.OpaqueData(b'{"c":{}}'), W().raw(b'{"c":{}}').b),
    ("opaque_cmd", 51, CM, 2, sm.OpaqueData(b"abcde"), W().raw(b"abcde").b),
    ("opaque_req", 51, R, 1, sm.OpaqueData(b""), W().raw(b"").b),
    ("imu_state", 60, D, 1, imu.ImuDataState(P3), p3(W()).b),
    ("imu_calib", 60, D, 2, CAL, W().f(*CAL_VALUES).b),
    ("imu_quat", 60, D, 3, imu.ImuDataQuat(CAL, 0.5, 0.0, 0.25, -0.75),
     W().f(*CAL_VALUES).f(0.5, 0.0, 0.25, -0.75).b),
    ("imu_euler", 60, D, 4, imu.ImuDataEuler(CAL, imu.Orientation3d(0.0, 0.25, -1.0)),
     W().f(*CAL_VALUES).d(0.0, 0.25, -1.0).b),
    ("imu_fullstate", 60, D, 5, imu.ImuDataFullstate(P3, P3, Pose3d()),
     p3(p3(W())).d(*[0.0] * 6).b),
    ("imu_datatype", 60, R, 1, imu.ImuDatatypeConfig(4), W().u(4).b),
    ("imu_reset", 60, R, 2, imu.ImuResetOrientationConfig(7), W().u(7).b),
    ("ranger", 62, D, 1, sm.RangerDataRange((1.0, 2.0)), W().u(2, 2).d(1.0, 2.0).b),
    ("ranger_stamped", 62, D, 2,
     sm.RangerDataRangestamped(sm.RangerDataRange((1.0,)), 1, RG, 1, RC),
     rc(rg(W().u(1, 1).d(1.0).u(1)).u(1)).b),
    ("ranger_intns", 62, D, 3, sm.RangerDataIntns((0.5,)), W().u(1, 1).d(0.5).b),
    ("ranger_intns_stamped", 62, D, 4,
     sm.RangerDataIntnsstamped(sm.RangerDataIntns(()), 0, sm.RangerGeom(), 0, sm.RangerConfig()),
     W().u(0, 0, 0).d(*[0.0] * 9).u(0, 0, 0, 0, 0).d(*[0.0] * 7).b),
    ("ranger_geom_data", 62, D, 5, RG, rg(W()).b),
    ("ranger_geom", 62, R, 1, RG, rg(W()).b),
    ("ranger_power", 62, R, 2, sm.RangerPowerConfig(1), W().u(1).b),
    ("ranger_intns_req", 62, R, 3, sm.RangerPowerConfig(0), W().u(0).b),
    ("ranger_setcfg", 62, R, 4, RC, rc(W()).b),
    ("ranger_getcfg", 62, R, 5, RC, rc(W()).b),
]

EMPTY_CASES = [
    (1, R, 4), (1, S, 1), (3, CM, 1), (3, CM, 2), (3, CM, 3), (3, CM, 4), (3, CM, 5),
    (4, R, 6), (31, CM, 1), (31, CM, 2), (31, CM, 3),
    (4, R, 1), (6, R, 1), (6, R, 3), (62, R, 1), (62, R, 5), (1, R, 1),  # empty requests
    (60, R, 1), (60, R, 2),  # the imu's requests are answered with empty ACKs
]


def header_bytes(interf: int, index: int, t: int, st: int, ts: float, size: int) -> bytes:
    return W().u(0, 0, interf, index, t, st).d(ts).u(0, size).b


@pytest.mark.parametrize(("name", "interf", "mtype", "subtype", "body", "expected"), CASES,
                         ids=[c_[0] for c_ in CASES])
def test_golden_both_ways(
    name: str, interf: int, mtype: int, subtype: int, body: Any, expected: bytes
) -> None:
    wire = encode_message(interf, 2, mtype, subtype, body, timestamp=12.5)
    assert wire == header_bytes(interf, 2, mtype, subtype, 12.5, len(expected)) + expected
    dec = Decoder()
    dec.feed(wire)
    msg = dec.next_event()
    assert isinstance(msg, Message)
    assert msg.body == body
    assert (msg.interf, msg.index, msg.type, msg.subtype) == (interf, 2, mtype, subtype)
    assert msg.header.size == len(expected)
    assert dec.next_event() is NEED_DATA
    if mtype == R:  # replies use the request's struct
        for reply in (c.MsgType.RESP_ACK, c.MsgType.RESP_NACK):
            dec.feed(encode_message(interf, 2, reply, subtype, body))
            assert dec.next_event().body == body  # type: ignore[union-attr]


def test_every_declared_body_has_a_golden_case() -> None:
    covered = {(i, t, s) for _, i, t, s, _, _ in CASES} | set(EMPTY_CASES)
    declared = {k for k, cls in REGISTRY.items() if cls is not None}
    assert declared - covered == set()
    assert {s for _, _, t, s, _, _ in CASES if s >= 247} == set(UNIVERSAL_REQUESTS)


@pytest.mark.parametrize(("interf", "mtype", "subtype"), EMPTY_CASES)
def test_empty_bodies(interf: int, mtype: int, subtype: int) -> None:
    wire = encode_message(interf, 0, mtype, subtype, None, timestamp=1.0)
    assert wire == header_bytes(interf, 0, mtype, subtype, 1.0, 0)
    dec = Decoder()
    dec.feed(wire)
    msg = dec.next_event()
    assert isinstance(msg, Message) and msg.body is None


def test_literal_bytes_from_the_reference() -> None:
    # DATAMODE PULL from a client: header + 00000002 (44 bytes)
    wire = encode_message(1, 0, 3, 5, pm.DeviceDatamodeReq(2))
    assert wire.hex() == (
        "00000000" "00000000" "00000001" "00000000" "00000003" "00000005"
        "0000000000000000" "00000000" "00000004" "00000002"
    )
    # DEV open position2d:0, a 28-byte body
    assert encode_message(1, 0, 3, 3, pm.DeviceReq(DevAddr(0, 0, 4, 0), 1, "")).hex()[80:] == (
        "00000000" "00000000" "00000004" "00000000" "00000001" "00000000" "00000000"
    )
    # the ACK's driver name "probe_position2d" has count 17 (0x11) twice + 3 pad bytes
    ack = encode_message(1, 0, 4, 3, pm.DeviceReq(DevAddr(0, 6665, 4, 0), 1, "probe_position2d"))
    assert len(ack) == 40 + 48
    assert ack[40 + 20: 40 + 28].hex() == "0000001100000011"
    assert ack[-4:] == b"\0\0\0\0"[:1] + b"\0\0\0"
    # playerprop getdbl max_speed: 28-byte body
    body = encode_message(6, 0, 3, 252, pm.DblPropReq("max_speed", 0.0))[40:]
    assert body.hex() == "0000000a0000000a" + b"max_speed\0".hex() + "0000" + "00" * 8
    assert c.banner() == b"Player v.3.1.1-dev" + b"\0" * 14
