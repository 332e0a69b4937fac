"""Raw Player frames a hostile or broken client might send, and a bounded raw client.

Shared by the live fuzz test and the opt-in soak (loaded with ``sibling.load_sibling``).
Every frame class the server must survive: non-finite and huge numbers in properties,
commands and poses, world-changing simulation messages, random headers and bodies, XDR
arrays claiming huge counts, frames announcing more than the size limit, replace-rule and
request floods.
"""

from __future__ import annotations

import math
import random
import socket
import struct
import time
from collections.abc import Iterator

from player_server.protocol import constants as c
from player_server.protocol import encode_message
from player_server.protocol import player_msgs as pm
from player_server.protocol.common import DevAddr, Pose2d, Pose3d
from player_server.protocol.constants import Interface, MsgType
from player_server.protocol.header import HEADER_STRUCT

REQ, CMD = int(MsgType.REQ), int(MsgType.CMD)
PLAYER = int(Interface.PLAYER)
P2D = int(Interface.POSITION2D)
SIM = int(Interface.SIMULATION)
BAD_NUMBERS = (math.nan, math.inf, -math.inf, 1e200, -1e200, 1e38, 3.4e38)
INTERFACES = [int(i) for i in Interface]


def frame(interf: int, index: int, mtype: int, subtype: int, payload: bytes = b"",
          size: int | None = None) -> bytes:
    """A header (any size claimed) and a payload, as raw bytes."""
    n = len(payload) if size is None else size
    return HEADER_STRUCT.pack(0, 0, interf & 0xFFFFFFFF, index & 0xFFFFFFFF, mtype & 0xFFFFFFFF,
                              subtype & 0xFFFFFFFF, 0.0, 0, n & 0xFFFFFFFF) + payload


def subscribe(interf: int, index: int = 0) -> bytes:
    return encode_message(PLAYER, 0, REQ, c.PLAYER_REQ_DEV,
                          pm.DeviceReq(DevAddr(0, 0, interf, index), c.PLAYER_OPEN_MODE, ""))


def datamode(mode: int) -> bytes:
    return encode_message(PLAYER, 0, REQ, c.PLAYER_REQ_DATAMODE, pm.DeviceDatamodeReq(mode))


def req_data() -> bytes:
    return encode_message(PLAYER, 0, REQ, c.PLAYER_REQ_DATA)


def dbl_prop(interf: int, key: str, value: float) -> bytes:
    return encode_message(interf, 0, REQ, c.PLAYER_SET_DBLPROP_REQ, pm.DblPropReq(key, value))


def velocity(vx: float, vyaw: float) -> bytes:
    return frame(P2D, 0, CMD, c.PLAYER_POSITION2D_CMD_VEL,
                 struct.pack(">dddI", vx, 0.0, vyaw, 1))


def vel_head(v: float, angle: float) -> bytes:
    return frame(P2D, 0, CMD, c.PLAYER_POSITION2D_CMD_VEL_HEAD, struct.pack(">dd", v, angle))


def position_goal(x: float, y: float, yaw: float) -> bytes:
    return frame(P2D, 0, CMD, c.PLAYER_POSITION2D_CMD_POS,
                 struct.pack(">ddddddI", x, y, yaw, 0.0, 0.0, 0.0, 1))


def set_pose2d(name: str, x: float, y: float, yaw: float) -> bytes:
    from player_server.protocol import simulation_msgs as simm
    return encode_message(SIM, 0, REQ, c.PLAYER_SIMULATION_REQ_SET_POSE2D,
                          simm.SimulationPose2dReq(name, Pose2d(x, y, yaw)))


def set_pose3d(name: str, x: float, y: float, yaw: float) -> bytes:
    from player_server.protocol import simulation_msgs as simm
    return encode_message(SIM, 0, REQ, c.PLAYER_SIMULATION_REQ_SET_POSE3D,
                          simm.SimulationPose3dReq(name, Pose3d(x, y, 0.0, 0.0, 0.0, yaw), 0.0))


def sim_command(subtype: int) -> bytes:
    return frame(SIM, 0, CMD, subtype)


def hostile_frames(rng: random.Random, robot: str) -> Iterator[bytes]:
    """An endless, seeded mix of every hostile class (after subscribing what they need)."""
    yield subscribe(P2D)
    yield subscribe(SIM)
    yield subscribe(int(Interface.LASER))
    kinds = 12
    while True:
        k = rng.randrange(kinds)
        bad = rng.choice(BAD_NUMBERS)
        if k == 0:
            yield dbl_prop(P2D, rng.choice(("max_speed", "max_yaw_rate", "position_tolerance_m",
                                            "heading_tolerance_rad")), bad)
        elif k == 1:
            yield velocity(bad, rng.choice((0.5, bad)))
        elif k == 2:
            yield vel_head(rng.choice((0.2, bad)), bad)
        elif k == 3:
            yield position_goal(bad, rng.uniform(-1, 1), rng.choice((0.0, bad)))
        elif k == 4:
            maker = set_pose2d if rng.random() < 0.5 else set_pose3d
            yield maker(rng.choice((robot, "box1", "nobody")), bad, rng.choice((0.0, bad)), 0.0)
        elif k == 5:
            yield sim_command(rng.choice((c.PLAYER_SIMULATION_CMD_PAUSE,
                                          c.PLAYER_SIMULATION_CMD_RESET)))
        elif k == 6:  # random header, random body
            body = rng.randbytes(rng.randrange(0, 200))
            yield frame(rng.choice(INTERFACES), rng.randrange(3), rng.randrange(1, 9),
                        rng.randrange(0, 260), body)
        elif k == 7:  # an XDR array that claims a huge count
            body = struct.pack(">II", 0x7FFFFFFF, 0x7FFFFFFF) + rng.randbytes(16)
            yield frame(rng.choice(INTERFACES), 0, rng.choice((REQ, CMD)),
                        rng.randrange(1, 12), body)
        elif k == 8:
            yield encode_message(PLAYER, 0, REQ, c.PLAYER_REQ_ADD_REPLACE_RULE,
                                 pm.AddReplaceRuleReq(-1, -1, -1, -1, rng.randrange(-5, 5)))
        elif k == 9:  # laser config nonsense (float32: what does not fit becomes inf)
            f = bad if abs(bad) < 3.4e38 or not math.isfinite(bad) else math.copysign(math.inf,
                                                                                      bad)
            body = struct.pack(">fffffIf", f, f, rng.choice((0.0, f)), f, 0.0,
                               rng.randrange(2), f)
            yield frame(int(Interface.LASER), 0, REQ, c.PLAYER_LASER_REQ_SET_CONFIG, body)
        elif k == 10:  # a request to the player device with a body that does not fit
            yield frame(PLAYER, 0, REQ, rng.randrange(0, 12), rng.randbytes(rng.randrange(9)))
        else:
            yield req_data()


class RawClient:
    """A blocking raw TCP client with bounded waits (reads the banner on connect)."""

    def __init__(self, port: int, *, nodelay: bool = True, timeout_s: float = 10.0) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout_s)
        if nodelay:
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.banner = self._exactly(c.BANNER_SIZE)

    def _exactly(self, n: int) -> bytes:
        buf = bytearray()
        while len(buf) < n:
            chunk = self.sock.recv(n - len(buf))
            if not chunk:
                raise ConnectionError("closed by the server")
            buf += chunk
        return bytes(buf)

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def read_message(self) -> tuple[tuple[int, ...], bytes]:
        header = HEADER_STRUCT.unpack(self._exactly(HEADER_STRUCT.size))
        return header, self._exactly(header[8])

    def wait_reply(self, interf: int, subtype: int, limit: int = 10_000) -> int:
        """Read until the ACK/NACK of (interf, subtype); returns its type."""
        for _ in range(limit):
            h, _body = self.read_message()
            if h[2] == interf and h[5] == subtype and h[4] in (int(MsgType.RESP_ACK),
                                                              int(MsgType.RESP_NACK)):
                return int(h[4])
        raise AssertionError(f"no reply to {interf}:{subtype} in {limit} messages")

    def drain(self, seconds: float = 0.05) -> int:
        """Read and drop whatever arrives for a short while (at most 100 reads); bytes read.

        The socket's timeout (or non-blocking mode) is restored afterwards.
        """
        before = self.sock.gettimeout()
        self.sock.settimeout(seconds)
        n = 0
        try:
            for _ in range(100):
                chunk = self.sock.recv(1 << 16)
                if not chunk:
                    break
                n += len(chunk)
        except (TimeoutError, BlockingIOError):
            pass
        finally:
            self.sock.settimeout(before)
        return n

    def closed_by_server(self, timeout_s: float = 20.0) -> bool:
        """Read until EOF or reset (True) or until ``timeout_s`` passes (False)."""
        deadline = time.monotonic() + timeout_s
        self.sock.settimeout(0.5)
        try:
            while time.monotonic() < deadline:
                try:
                    if not self.sock.recv(1 << 20):
                        return True
                except TimeoutError:
                    continue
                except OSError:
                    return True
            return False
        finally:
            self.sock.settimeout(10.0)

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> RawClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
